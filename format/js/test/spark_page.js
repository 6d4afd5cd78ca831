// Test page of Spark skinning (spark_skinning_test.mjs; page.html?engine=spark): a plain
// three.js application that loads a `haha pack --khr-gaussian-splatting` avatar with GLTFLoader
// (+ DRACOLoader, served locally), builds a Spark SplatMesh from the skinned KHR_gaussian_splatting primitive (node 56:
// mesh 1, skin 0) and drives Spark's SplatSkinning from the glTF skeleton. No HAHA plugin: only
// what the standard glTF part of the file (format/spec.md section 2) gives any engine.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { ExtSplats, SparkRenderer, SplatMesh, SplatSkinning, SplatSkinningMode } from '@sparkjsdev/spark';
import { threeApp, poseBones, applyOpenCvCamera, toBase64, typedBase64 as b64, readRgba, topDownRgb } from './page_common.js';

const { renderer, scene, camera, draco } = threeApp(THREE, DRACOLoader);
const SH_C0 = 0.28209479177387814;
let spark, gltf, bones, boneInverses, splats, skinning, helper, rootRest, file;

// Spark keeps 8 bits per weight (round(w * 255)) and does not renormalise: weights whose codes
// do not sum to 255 scale the splat about the origin (1/255 = 4 mm per metre). So: 8-bit codes
// summing to exactly 255, each weight but the largest rounded, the largest takes the rest.
function weights255(w) {
  const code = [0, 0, 0, 0];
  let sum = 0, big = 0;
  for (let k = 1; k < 4; k++) if (w[k] > w[big]) big = k;
  for (let k = 0; k < 4; k++) if (k !== big) { code[k] = Math.round(w[k] * 255); sum += code[k]; }
  code[big] = 255 - sum;
  return code;
}

export default {
  async load(url) {
    // Covariance splats in an extended (float32 centre) accumulator: what Spark's linear
    // blend skinning needs (its default accumulator takes no covariance generator).
    spark = new SparkRenderer({ renderer, covSplats: true, accumExtSplats: true });
    scene.add(spark);
    gltf = await new GLTFLoader().setDRACOLoader(draco).loadAsync(url);
    scene.add(gltf.scene);  // the joint nodes; its meshes are hidden: Spark draws the splats
    gltf.scene.traverse((o) => { if (o.isMesh || o.isPoints) o.visible = false; });
    const json = gltf.parser.json;
    const node = json.nodes.findIndex((n) => n.mesh !== undefined && json.meshes[n.mesh].primitives[0].mode === 0);
    if (node < 0) throw new Error('no POINTS primitive (pack with --khr-gaussian-splatting)');
    const prim = json.meshes[json.nodes[node].mesh].primitives[0];
    const acc = async (name) => {
      if (prim.attributes[name] === undefined) throw new Error(`splat primitive without ${name}`);
      return gltf.parser.getDependency('accessor', prim.attributes[name]);
    };
    const pos = await acc('POSITION'), rot = await acc('KHR_gaussian_splatting:ROTATION'), scl = await acc('KHR_gaussian_splatting:SCALE');
    const opa = await acc('KHR_gaussian_splatting:OPACITY'), sh0 = await acc('KHR_gaussian_splatting:SH_DEGREE_0_COEF_0');
    const joints = await acc('JOINTS_0'), weights = await acc('WEIGHTS_0');
    const N = pos.count;
    // The skeleton of the splat node's skin: the joint nodes (posed below) and the IBMs.
    const skeleton = await gltf.parser.getDependency('skin', json.nodes[node].skin);  // THREE.Skeleton of the scene's joint nodes
    bones = skeleton.bones; boneInverses = skeleton.boneInverses;
    rootRest = bones[0].position.clone();
    // Spark: ExtSplats (float32 centres; PackedSplats would store them as float16) with
    // covariance splats, which its linear blend skinning requires. Spark 2.2.0 uploads an
    // ExtSplats' textures only when it is given its arrays (not after pushSplat /
    // constructSplats: it then draws nothing), so the splats are encoded into a scratch
    // ExtSplats and its arrays handed to the one the mesh draws.
    const c = new THREE.Vector3(), s = new THREE.Vector3(), q = new THREE.Quaternion(), col = new THREE.Color();
    const scratch = new ExtSplats({ maxSplats: N });
    for (let i = 0; i < N; i++) {
      c.fromBufferAttribute(pos, i); s.fromBufferAttribute(scl, i);
      q.set(rot.getX(i), rot.getY(i), rot.getZ(i), rot.getW(i));
      col.setRGB(0.5 + SH_C0 * sh0.getX(i), 0.5 + SH_C0 * sh0.getY(i), 0.5 + SH_C0 * sh0.getZ(i));
      scratch.pushSplat(c, s, q, opa.getX(i), col);
    }
    splats = new SplatMesh({ extSplats: new ExtSplats({ extArrays: scratch.extArrays, numSplats: N }), covSplats: true });
    await splats.initialized;
    skinning = new SplatSkinning({ mesh: splats, numSplats: N, numBones: bones.length, mode: SplatSkinningMode.LINEAR_BLEND });
    const jv = new THREE.Vector4(), wv = new THREE.Vector4(), w = [0, 0, 0, 0];
    for (let i = 0; i < N; i++) {
      for (let k = 0; k < 4; k++) w[k] = weights.getComponent(i, k);  // normalized ushort -> [0, 1]
      const code = weights255(w);
      jv.fromBufferAttribute(joints, i);
      wv.set(code[0] / 255, code[1] / 255, code[2] / 255, code[3] / 255);
      skinning.setSplatBones(i, jv, wv);
    }
    // Identity rest: Spark's linear blend then applies the bone matrix as given, and we give
    // it glTF's skin matrix B_j * IBM_j (setBoneMatrix computes restInverse * matrix).
    for (let j = 0; j < bones.length; j++) skinning.setRestMatrix(j, new THREE.Matrix4());
    splats.skinning = skinning;
    splats.updateGenerator();
    scene.add(splats);
    // A helper SkinnedMesh on the same skeleton and the file's own JOINTS_0/WEIGHTS_0
    // (16-bit weights): three.js's skinning maths (applyBoneTransform) as the reference.
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', pos); g.setAttribute('skinIndex', joints); g.setAttribute('skinWeight', weights);
    helper = new THREE.SkinnedMesh(g, new THREE.MeshBasicMaterial());
    helper.bind(new THREE.Skeleton(bones, boneInverses), new THREE.Matrix4());
    file = { N, pos, joints, weights };
    return { N, node, mesh: json.nodes[node].mesh, skin: json.nodes[node].skin, bones: bones.length,
      weightType: weights.array.constructor.name, weightNormalized: weights.normalized, jointType: joints.array.constructor.name };
  },
  // SMPL-X pose set on the glTF joint nodes, then Spark's bones driven from them.
  setPose(pose, transl) {
    poseBones(THREE, bones, pose, transl, rootRest);
    gltf.scene.updateMatrixWorld(true);
    const m = new THREE.Matrix4();
    for (let j = 0; j < bones.length; j++) skinning.setBoneMatrix(j, m.multiplyMatrices(bones[j].matrixWorld, boneInverses[j]));
    skinning.updateBones();
  },
  // What Spark's shader reads (the skin and bone textures' data, the splats' float32 centres),
  // three.js's skinned centres of the file's weights (float64), and the file's arrays.
  data() {
    const N = file.N, ref = new Float64Array(3 * N), v = new THREE.Vector3();
    for (let i = 0; i < N; i++) {
      helper.applyBoneTransform(i, v.fromBufferAttribute(file.pos, i));
      ref[3 * i] = v.x; ref[3 * i + 1] = v.y; ref[3 * i + 2] = v.z;
    }
    return {
      N, threeLbs: b64(ref), skinData: b64(skinning.skinData.subarray(0, 4 * N)), boneData: b64(skinning.boneData),
      sparkCentres: b64(splats.extSplats.extArrays[0].subarray(0, 4 * N)), position: b64(Float32Array.from(file.pos.array)),
      joints: b64(Uint8Array.from(file.joints.array)), weights: b64(Uint16Array.from(file.weights.array)),
    };
  },
  // Renders (Spark sorts in a worker: a few frames until the image settles).
  async render(cam) {
    renderer.setSize(cam.width, cam.height, false);
    applyOpenCvCamera(cam, camera);
    const gl = renderer.getContext(), rgba = new Uint8Array(4 * cam.width * cam.height);
    let last = null, same = 0, frames = 0;
    const t0 = performance.now();
    while (performance.now() - t0 < 30000) {
      renderer.render(scene, camera);
      frames++;
      readRgba(gl, cam.width, cam.height, rgba);
      const now = toBase64(rgba), lit = rgba.some((v, i) => (i & 3) !== 3 && v > 8);
      same = lit && now === last ? same + 1 : 0;
      if (same >= 3) break;
      last = now;
      await new Promise((r) => setTimeout(r, 100));
    }
    this.frames = frames;
    return toBase64(topDownRgb(rgba, cam.width, cam.height));
  },
};
