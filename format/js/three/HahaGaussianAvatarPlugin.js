// three.js GLTFLoader plugin for HAHA avatars (.glb + HAHA_gaussian_avatar, format/spec.md,
// versions 1 to 4): the loaded gltf.scene keeps the standard skinned, textured body that
// GLTFLoader makes, plus a HahaGaussianLayer: the face-bound Gaussians, reposed every frame
// from the skeleton's bones with the exact triangle-bound maths of the haha loader (linear
// blend skinning with every influence and the embedded pose correctives, face frames of the
// posed mesh; ../avatar.js) and splatted like `haha render` (3DGS EWA, sorted by depth, hidden
// behind the mesh by the depth buffer; ../splat.js). Bones driven by an AnimationMixer or set
// by hand (bone.quaternion) move the Gaussians with the body: the file's own animations
// (gltf.animations, `haha pack --animation`) play with
//   new THREE.AnimationMixer(gltf.scene).clipAction(gltf.animations[0]).play()  // + mixer.update(dt)
//
//   const draco = new DRACOLoader().setDecoderPath('/node_modules/three/examples/jsm/libs/draco/');
//   const loader = new GLTFLoader().setDRACOLoader(draco);
//   loader.register((parser) => new HahaGaussianAvatarPlugin(parser, { dracoLoader: draco }));
//   const gltf = await loader.loadAsync('avatar.glb');
//   scene.add(gltf.scene);                        // gltf.userData.hahaAvatar: the layer
//
// Options: dracoLoader (decodes the Gaussians' Draco point cloud; default: the loader's own,
// when the body mesh is Draco-compressed), exactBody (false: the body is GLTFLoader's GPU-
// skinned mesh, 4 influences, no pose correctives; true: it is drawn from the loader's exact
// CPU-posed vertices instead, as `haha render` poses it), hideSplatPrimitive (true: the
// optional KHR_gaussian_splatting points, which three.js draws as dots, are hidden), name (for
// error messages).
import * as THREE from 'three';
import { Avatar, NUM_JOINTS } from '../avatar.js';
import { Glb } from '../glb.js';
import { SplatTexture, splatLayerShaders, openCvFromGl } from '../splat.js';

export const EXTENSION_NAME = 'HAHA_gaussian_avatar';

// The avatar reader's Draco decode function over a three.js DRACOLoader (worker pool).
export function dracoLoaderDecode(dracoLoader) {
  return (bytes, ids, types) => new Promise((resolve, reject) => {
    dracoLoader.decodeDracoFile(bytes.slice().buffer, (geom) => {
      const out = { index: geom.index ? geom.index.array : null };
      for (const k of Object.keys(ids)) out[k] = geom.attributes[k].array;
      resolve(out);
    }, ids, types, THREE.LinearSRGBColorSpace, reject);
  });
}

export class HahaGaussianAvatarPlugin {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = EXTENSION_NAME;
    this.options = options;
  }

  async afterRoot(result) {
    const parser = this.parser, json = parser.json;
    const ext = json.extensions && json.extensions[EXTENSION_NAME];
    if (!ext) return;  // a plain glTF: nothing to add
    const name = this.options.name || 'avatar.glb';
    const draco = this.options.dracoLoader ||
      (parser.extensions.KHR_draco_mesh_compression && parser.extensions.KHR_draco_mesh_compression.dracoLoader);
    if (!draco) throw new Error(`${name}: ${EXTENSION_NAME}: the Gaussians are a Draco point cloud: pass { dracoLoader } to HahaGaussianAvatarPlugin`);
    const bin = await parser.getDependency('buffer', 0);
    const avatar = await Avatar.load(Glb.fromParts(json, bin, name), dracoLoaderDecode(draco), name);

    // The objects GLTFLoader made for the avatar's nodes (parser.associations: object -> node).
    const byNode = new Map();
    result.scene.traverse((o) => {
      const a = parser.associations.get(o);
      if (a && a.nodes !== undefined && !byNode.has(a.nodes)) byNode.set(a.nodes, o);
    });
    // A body mesh of several primitives (version 4: the body, then a garment) loads as a
    // group of skinned meshes, one per primitive, in primitive order.
    const node = byNode.get(ext.body.node);
    const parts = [];
    if (node) node.traverse((o) => { if (o.isSkinnedMesh) parts.push(o); });
    const body = parts[0];
    if (!body || !body.isSkinnedMesh) throw new Error(`${name}: ${EXTENSION_NAME}: body node ${ext.body.node} is not a skinned mesh in the loaded scene`);
    if (body.skeleton.bones.length !== NUM_JOINTS) throw new Error(`${name}: skin: must have exactly ${NUM_JOINTS} joints (SMPL-X)`);
    if (ext.splats && this.options.hideSplatPrimitive !== false) {
      const s = byNode.get(ext.splats.node);
      if (s) s.visible = false;
    }
    const layer = new HahaGaussianLayer(avatar, body, { ...this.options, bodyParts: parts });
    result.scene.add(layer);
    result.userData.hahaAvatar = layer;
  }
}

// The splat layer's GLSL (../splat.js) in three.js's dialect (ShaderMaterial, GLSL3). Colours
// are display-referred like the texture: to linear, then to the output space.
const SPLAT_SHADERS = splatLayerShaders({
  vertexOut: 'out', fragmentIn: 'in', fragmentHead: 'out vec4 hahaColor;',
  writeColor: `vec4 c = linearToOutputTexel(sRGBTransferEOTF(vec4(vColor, 1.0)));
  hahaColor = vec4(c.rgb * alpha, alpha);`,
});

// The Gaussian layer: a child of gltf.scene (its frame is the avatar's glTF frame). update()
// reposes from the bones (run automatically when the world matrices are updated and before
// each render); the splats are projected for each camera that renders it.
export class HahaGaussianLayer extends THREE.Mesh {
  constructor(avatar, skinnedMesh, options = {}) {
    const N = avatar.N;
    const splats = new SplatTexture(N);
    const texture = new THREE.DataTexture(splats.data, splats.width, splats.height, THREE.RGBAFormat, THREE.FloatType);
    texture.minFilter = texture.magFilter = THREE.NearestFilter;
    texture.generateMipmaps = false;
    texture.needsUpdate = true;
    const geometry = new THREE.BufferGeometry();
    geometry.setIndex(new THREE.BufferAttribute(splats.indices, 1));
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(4 * Math.max(1, N)), 1));  // unused: gl_VertexID
    geometry.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    geometry.setDrawRange(0, 0);
    const material = new THREE.ShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: SPLAT_SHADERS.vertex, fragmentShader: SPLAT_SHADERS.fragment,
      uniforms: { splats: { value: texture }, hahaViewport: { value: new THREE.Vector4() } },
      transparent: true, depthTest: true, depthWrite: false, depthFunc: THREE.LessEqualDepth,
      blending: THREE.CustomBlending, blendEquation: THREE.AddEquation,
      blendSrc: THREE.OneFactor, blendDst: THREE.OneMinusSrcAlphaFactor,
      blendSrcAlpha: THREE.OneFactor, blendDstAlpha: THREE.OneMinusSrcAlphaFactor,
      side: THREE.DoubleSide, forceSinglePass: true,
    });
    super(geometry, material);
    this.name = 'HAHA_gaussians';
    this.frustumCulled = false;
    this.avatar = avatar;
    this.skinnedMesh = skinnedMesh;
    this.bodyParts = options.bodyParts || [skinnedMesh];  // one skinned mesh per primitive of the body mesh
    this.bones = skinnedMesh.skeleton.bones;
    this.splats = splats;
    this.projector = splats.projector;
    this.splatData = splats.data;
    this.splatTexture = texture;
    this.visibleSplats = 0;
    this._signature = new Float64Array(16 * (NUM_JOINTS + 1)).fill(NaN);
    this._toAvatar = new THREE.Matrix4();
    this._m = new THREE.Matrix4();
    this._viewport = new THREE.Vector4();
    if (options.exactBody) this._makeExactBody();
  }

  // Reposes the avatar from the current bone world matrices if they changed since the last
  // call (returns true then): this.avatar.posed (body vertices) and this.avatar.means /
  // quats (w, x, y, z) / scales, in the avatar's glTF frame (this layer's frame).
  update() {
    const bones = this.bones, sig = this._signature;
    let changed = false;
    const check = (e, o) => {
      for (let k = 0; k < 16; k++) if (sig[o + k] !== e[k]) { sig[o + k] = e[k]; changed = true; }
    };
    for (let j = 0; j < NUM_JOINTS; j++) check(bones[j].matrixWorld.elements, 16 * j);
    check(this.matrixWorld.elements, 16 * NUM_JOINTS);
    if (!changed) return false;
    const a = this.avatar, sk = this.skinnedMesh;
    const toAvatar = this._toAvatar.copy(this.matrixWorld).invert();
    const m = this._m;
    // Skinning matrix of joint j in the avatar frame: the SkinnedMesh's own rule (attached
    // bind mode): bone.matrixWorld * boneInverse * bindMatrix, seen from this layer.
    const { A, feat } = a.skinningFromMatrices(
      (j) => m.multiplyMatrices(toAvatar, bones[j].matrixWorld).multiply(sk.skeleton.boneInverses[j]).multiply(sk.bindMatrix).elements,
      (j) => { const q = bones[j].quaternion; return [q.x, q.y, q.z, q.w]; });
    a.reposeBodyWith(A, feat);
    a.poseGaussians();
    if (this.exactBody) this._updateExactBody();
    return true;
  }

  updateMatrixWorld(force) {
    super.updateMatrixWorld(force);
    this.update();  // bones come first in gltf.scene, so theirs are current here
  }

  // World-space centres of the Gaussians (Float64Array, N x 3) after update().
  worldMeans(out = new Float64Array(3 * this.avatar.N)) {
    return this.avatar.transformedMeans(this.matrixWorld.elements, out);
  }

  onBeforeRender(renderer, scene, camera) {
    this.update();
    const cam = this._openCvCamera(renderer, camera);
    const mat = this.material;
    if (!cam) { this.geometry.setDrawRange(0, 0); return; }
    cam.depthMargin = this.avatar.depthMargin;
    const n = this.splats.project(cam, this.avatar);
    this.splatTexture.needsUpdate = true;  // uploaded when the material binds it, this frame
    mat.uniforms.hahaViewport.value.copy(this._viewport);
    this.geometry.setDrawRange(0, 6 * n);
    this.visibleSplats = n;
  }

  // The OpenCV pinhole camera (splat.js) from the avatar frame to the pixels of the current
  // viewport, or null for a camera that is not a perspective projection.
  _openCvCamera(renderer, camera) {
    const P = camera.projectionMatrix.elements;
    if (P[11] !== -1 || P[15] !== 0) {
      if (!this._warned) { console.warn(`${EXTENSION_NAME}: only perspective cameras draw the Gaussians`); this._warned = true; }
      return null;
    }
    const vp = renderer.getCurrentViewport(this._viewport);
    const W = vp.z, H = vp.w;
    // OpenCV extrinsics: diag(1, -1, -1) * viewMatrix * (avatar frame -> world).
    const E = this._m.multiplyMatrices(camera.matrixWorldInverse, this.matrixWorld).elements;
    return openCvFromGl(P, E, W, H, P[14] / (P[10] - 1));
  }

  // exactBody: the body drawn from the CPU-posed vertices (every influence, pose correctives)
  // instead of GPU skinning, one mesh per primitive (each a slice of the avatar's glTF
  // vertices); the SkinnedMeshes are hidden.
  _makeExactBody() {
    const a = this.avatar;
    const total = this.bodyParts.reduce((n, sk) => n + sk.geometry.attributes.position.count, 0);
    if (total !== a.Vg) throw new Error(`${EXTENSION_NAME}: the body mesh has ${total} vertices, the avatar ${a.Vg}`);
    this._exactPositions = new THREE.BufferAttribute(new Float32Array(3 * a.Vg), 3);  // every part's, for posedGltfVertices
    this._exactParts = [];
    const group = new THREE.Group();
    group.name = 'HAHA_exact_body';
    let at = 0;
    for (const sk of this.bodyParts) {
      const n = sk.geometry.attributes.position.count;
      const g = new THREE.BufferGeometry();
      if (sk.geometry.index) g.setIndex(sk.geometry.index);
      // 'color': the mesh coverage (COLOR_0 alpha), which the material's alphaTest cuts by.
      for (const k of ['uv', 'normal', 'color']) if (sk.geometry.attributes[k]) g.setAttribute(k, sk.geometry.attributes[k]);
      const pos = new THREE.BufferAttribute(this._exactPositions.array.subarray(3 * at, 3 * (at + n)), 3);
      pos.setUsage(THREE.DynamicDrawUsage);
      g.setAttribute('position', pos);
      g.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
      const mesh = new THREE.Mesh(g, sk.material);
      mesh.name = 'HAHA_exact_body_' + this._exactParts.length;
      mesh.frustumCulled = false;
      sk.visible = false;
      this._exactParts.push(pos);
      group.add(mesh);
      at += n;
    }
    this.exactBody = group;
    this.add(group);
  }

  _updateExactBody() {
    this.avatar.posedGltfVertices(this._exactPositions.array);
    for (const p of this._exactParts) p.needsUpdate = true;
  }
}
