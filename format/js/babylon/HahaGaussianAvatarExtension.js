// Babylon.js glTF loader extension for HAHA avatars (.glb + HAHA_gaussian_avatar,
// format/spec.md, versions 1 to 3): the loaded scene keeps Babylon's skinned, textured body
// and gets a Gaussian layer, reposed every frame from the skeleton's joint nodes with the
// exact triangle-bound maths of the haha loader (every skin influence, the embedded pose
// correctives, face frames of the posed mesh: ../avatar.js) and splatted like `haha render`
// (3DGS EWA, depth-sorted, hidden behind the body by the depth buffer: ../splat.js).
// Animation groups or hand-set rotations (node.rotationQuaternion) of the joints move it: the
// file's own animations (`haha pack --animation`) are the loader's scene.animationGroups.
//
//   import { registerHahaGaussianAvatar } from './format/js/babylon/HahaGaussianAvatarExtension.js';
//   BABYLON.DracoDecoder.DefaultConfiguration = { wasmUrl, wasmBinaryUrl, fallbackUrl };  // local files
//   const dracoModule = await DracoDecoderModule({ wasmBinary });  // Emscripten Draco decoder
//   registerHahaGaussianAvatar(BABYLON, { dracoDecoderModule: dracoModule });
//   const result = await BABYLON.SceneLoader.ImportMeshAsync('', '', 'avatar.glb', scene);
//   const layer = scene.metadata.hahaAvatars[0];   // HahaGaussianLayer
//
// BABYLON: the namespace (UMD global, or an object holding the classes used here from
// @babylonjs/core and @babylonjs/loaders). Options: dracoDecoderModule (an initialised
// Emscripten Draco decoder module, e.g. three.js's libs/draco or npm draco3dgltf: the
// Gaussians are a Draco point cloud with GENERIC attributes), exactBody (false: the body is
// Babylon's GPU-skinned mesh, no pose correctives; true: drawn from the exact CPU-posed
// vertices instead, as `haha render` poses it), hideSplatPrimitive (true: the optional
// KHR_gaussian_splatting mesh, which Babylon leaves in the rest pose, is disabled).
import { Avatar, NUM_JOINTS } from '../avatar.js';
import { Glb } from '../glb.js';
import { dracoDecode } from '../draco.js';
import { SplatTexture, splatLayerShaders, openCvFromGl } from '../splat.js';

export const EXTENSION_NAME = 'HAHA_gaussian_avatar';

export function registerHahaGaussianAvatar(BABYLON, options = {}) {
  const factory = (loader) => new HahaGaussianAvatarExtension(BABYLON, loader, options);
  if (BABYLON.registerGLTFExtension) BABYLON.registerGLTFExtension(EXTENSION_NAME, false, factory);
  else BABYLON.GLTF2.GLTFLoader.RegisterExtension(EXTENSION_NAME, factory);
}

export class HahaGaussianAvatarExtension {
  constructor(BABYLON, loader, options) {
    this.B = BABYLON;
    this.name = EXTENSION_NAME;
    this.enabled = !!(loader.gltf.extensionsUsed && loader.gltf.extensionsUsed.includes(EXTENSION_NAME));
    this._loader = loader;
    this.options = options;
  }

  dispose() { this._loader = null; }

  // The scene loads as usual; then the avatar's extension data is read and the layer attached.
  loadSceneAsync(context, scene) {
    const loader = this._loader, gltf = loader.gltf;
    const ext = gltf.extensions && gltf.extensions[EXTENSION_NAME];
    if (!ext) return null;
    const name = this.options.name || 'avatar.glb';
    return Promise.all([loader.loadSceneAsync(context, scene), this._readAvatar(ext, name)]).then(([, avatar]) => {
      const node = (i) => gltf.nodes[i] && gltf.nodes[i]._babylonTransformNode;
      const joints = gltf.skins[ext.body.skin].joints.map(node);
      if (joints.length !== NUM_JOINTS || joints.some((n) => !n)) throw new Error(`${name}: skin: the ${NUM_JOINTS} joint nodes were not loaded`);
      if (ext.splats && this.options.hideSplatPrimitive !== false && node(ext.splats.node)) node(ext.splats.node).setEnabled(false);
      const ibm = avatar.glb.readAccessor(gltf.skins[ext.body.skin].inverseBindMatrices, 16, 'skin.inverseBindMatrices').values;
      const layer = new HahaGaussianLayer(this.B, loader.babylonScene, avatar, joints, ibm, loader.rootBabylonMesh, node(ext.body.node));
      // The mesh coverage (COLOR_0 alpha, alphaMode MASK): Babylon's KHR_draco_mesh_compression
      // loads COLOR_0 but, unlike plain accessors, never marks a VEC4 one as carrying alpha, so
      // the alpha test would keep the whole mesh.
      if (avatar.meshCoverage) {
        for (const m of layer.bodyParts) if (m.isVerticesDataPresent(this.B.VertexBuffer.ColorKind)) m.hasVertexAlpha = true;
      }
      if (this.options.exactBody) layer.makeExactBody();
      const s = loader.babylonScene;
      s.metadata = s.metadata || {};
      (s.metadata.hahaAvatars = s.metadata.hahaAvatars || []).push(layer);
    });
  }

  async _readAvatar(ext, name) {
    const loader = this._loader;
    const mod = this.options.dracoDecoderModule;
    if (!mod) throw new Error(`${name}: ${EXTENSION_NAME}: the Gaussians are a Draco point cloud: pass { dracoDecoderModule } to registerHahaGaussianAvatar`);
    const bin = loader.bin ? await loader.bin.readAsync(0, loader.bin.byteLength) : new Uint8Array(0);
    const bytes = bin instanceof Uint8Array ? bin : new Uint8Array(bin.buffer, bin.byteOffset, bin.byteLength);
    return Avatar.load(Glb.fromParts(loader.gltf, bytes, name), dracoDecode(mod), name);
  }
}

// The splat layer's GLSL (../splat.js) in Babylon's dialect (its WebGL2 engine turns
// attribute / varying / gl_FragColor into GLSL ES 3.00). Babylon draws display-referred
// colours (gamma space), as the Gaussians' colours are.
const SPLAT_SHADERS = splatLayerShaders({
  vertexOut: 'varying', fragmentIn: 'varying',
  vertexHead: 'attribute vec3 position;  // unused (gl_VertexID picks the splat and corner)',
  clipW: '1.0 + 0.0 * position.x',
  writeColor: 'gl_FragColor = vec4(vColor * alpha, alpha);',
});

// Column-major 4 x 4 (Babylon's Matrix.m and three.js's elements share this layout) product a * b.
function mul(a, b, out = new Float64Array(16)) {
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
    out[4 * c + r] = a[r] * b[4 * c] + a[4 + r] * b[4 * c + 1] + a[8 + r] * b[4 * c + 2] + a[12 + r] * b[4 * c + 3];
  }
  return out;
}

function invertAffine(m, out = new Float64Array(16)) {
  const a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
  const det = a * A + b * B + c * C;
  const inv = [A / det, -(b * i - c * h) / det, (b * f - c * e) / det,
    B / det, (a * i - c * g) / det, -(a * f - c * d) / det,
    C / det, -(a * h - b * g) / det, (a * e - b * d) / det];  // row-major 3 x 3
  out.fill(0);
  for (let r = 0; r < 3; r++) {
    for (let k = 0; k < 3; k++) out[4 * k + r] = inv[3 * r + k];
    out[12 + r] = -(inv[3 * r] * m[12] + inv[3 * r + 1] * m[13] + inv[3 * r + 2] * m[14]);
  }
  out[15] = 1;
  return out;
}

// The Gaussian layer: a mesh drawn after the opaque body (alpha blended, no depth writes).
// update() reposes from the joint nodes' world matrices (run before every render); the
// splats are projected for each camera that renders the scene.
export class HahaGaussianLayer {
  constructor(BABYLON, scene, avatar, joints, ibm, root, bodyNode) {
    const B = BABYLON, N = avatar.N;
    this.B = B;
    this.scene = scene;
    this.avatar = avatar;
    this.joints = joints;    // TransformNode per SMPL-X joint
    this.ibm = ibm;          // (55, 16) inverse bind matrices, column-major
    this.root = root;        // the loader's __root__ node (the avatar's glTF frame -> world)
    this.bodyNode = bodyNode;
    const splats = new SplatTexture(N);
    this.splats = splats;
    this.projector = splats.projector;
    this.splatData = splats.data;
    this.texture = B.RawTexture.CreateRGBATexture(splats.data, splats.width, splats.height, scene, false, false,
      B.Constants.TEXTURE_NEAREST_SAMPLINGMODE, B.Constants.TEXTURETYPE_FLOAT);
    const mesh = new B.Mesh('HAHA_gaussians', scene);
    const positions = new Float32Array(3 * 4 * Math.max(1, N));
    mesh.setVerticesData(B.VertexBuffer.PositionKind, positions, false);
    mesh.setIndices(splats.indices, 4 * Math.max(1, N));
    mesh.alwaysSelectAsActiveMesh = true;
    mesh.isPickable = false;
    const material = new B.ShaderMaterial('HAHA_gaussians', scene, { vertexSource: SPLAT_SHADERS.vertex, fragmentSource: SPLAT_SHADERS.fragment }, {
      attributes: ['position'], uniforms: ['hahaViewport'], samplers: ['splats'], needAlphaBlending: true,
    });
    material.setTexture('splats', this.texture);
    material.backFaceCulling = false;
    material.disableDepthWrite = true;
    material.alphaMode = B.Constants.ALPHA_PREMULTIPLIED;
    material.depthFunction = B.Constants.LEQUAL;
    mesh.material = material;
    mesh.subMeshes[0].indexCount = 0;
    // A draw range short of every splat (some culled off screen) makes the sub-mesh non-global:
    // Babylon then sorts the transparent queue by the sub-mesh's own bounding info, which it
    // never made (a TypeError on 'boundingSphere' in every frame).
    mesh.subMeshes[0].setBoundingInfo(mesh.getBoundingInfo());
    this.mesh = mesh;
    this.material = material;
    this.visibleSplats = 0;
    this._sig = new Float64Array(16 * (NUM_JOINTS + 1)).fill(NaN);
    this._m = new Float64Array(16);
    this._m2 = new Float64Array(16);
    this._toAvatar = new Float64Array(16);
    this._beforeCamera = scene.onBeforeCameraRenderObservable.add((camera) => this._project(camera));
  }

  // Reposes the avatar from the joint nodes' current world matrices if they changed (returns
  // true then): this.avatar.posed / means / quats (w, x, y, z) / scales in the glTF frame.
  update() {
    const rootM = this.root ? this.root.computeWorldMatrix(true).m : null;
    const worlds = this.joints.map((n) => n.computeWorldMatrix(true).m);  // parents first
    let changed = false;
    const check = (e, o) => { for (let k = 0; k < 16; k++) if (this._sig[o + k] !== e[k]) { this._sig[o + k] = e[k]; changed = true; } };
    worlds.forEach((w, j) => check(w, 16 * j));
    if (rootM) check(rootM, 16 * NUM_JOINTS);
    if (!changed) return false;
    if (rootM) invertAffine(rootM, this._toAvatar);
    else this._toAvatar.set([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    const a = this.avatar, ibm = this.ibm;
    const { A, feat } = a.skinningFromMatrices(
      (j) => mul(mul(this._toAvatar, worlds[j], this._m2), ibm.subarray(16 * j, 16 * j + 16), this._m),
      (j) => {
        const q = this.joints[j].rotationQuaternion;
        if (q) return [q.x, q.y, q.z, q.w];
        const r = this.joints[j].rotation;  // Euler (Babylon's YXZ order)
        const qq = this.B.Quaternion.RotationYawPitchRoll(r.y, r.x, r.z);
        return [qq.x, qq.y, qq.z, qq.w];
      });
    a.reposeBodyWith(A, feat);
    a.poseGaussians();
    if (this.exactBody) this._updateExactBody();
    return true;
  }

  // exactBody: the body drawn from the CPU-posed vertices (every influence, pose correctives)
  // instead of Babylon's GPU skinning, one mesh per primitive of the body mesh (version 4:
  // the body, then a garment; Babylon makes a node of several primitives a parent of one
  // mesh each); the skinned meshes are disabled.
  makeExactBody() {
    const B = this.B, a = this.avatar;
    const parts = this.bodyParts;
    if (!parts.length) throw new Error(`${EXTENSION_NAME}: the body node is not a mesh`);
    const total = parts.reduce((n, m) => n + m.getTotalVertices(), 0);
    if (total !== a.Vg) throw new Error(`${EXTENSION_NAME}: the body mesh has ${total} vertices, the avatar ${a.Vg}`);
    this._exactPositions = new Float32Array(3 * a.Vg);
    this.exactParts = [];
    let at = 0;
    for (const part of parts) {
      const n = part.getTotalVertices();
      const mesh = new B.Mesh(`HAHA_exact_body_${this.exactParts.length}`, this.scene);
      mesh.setVerticesData(B.VertexBuffer.PositionKind, this._exactPositions.subarray(3 * at, 3 * (at + n)), true);
      const uv = part.getVerticesData(B.VertexBuffer.UVKind);
      if (uv) mesh.setVerticesData(B.VertexBuffer.UVKind, uv, false);
      // The mesh coverage (COLOR_0 alpha), which the material's alpha test cuts by.
      const color = part.getVerticesData(B.VertexBuffer.ColorKind);
      if (color) mesh.setVerticesData(B.VertexBuffer.ColorKind, color, false, 4);
      mesh.hasVertexAlpha = part.hasVertexAlpha;
      mesh.setIndices(part.getIndices(), n);
      mesh.material = part.material;
      for (const k of ['sideOrientation', 'overrideMaterialSideOrientation']) if (k in part) mesh[k] = part[k];  // the loader's winding rule
      mesh.parent = this.root;  // positions are in the avatar's glTF frame
      mesh.alwaysSelectAsActiveMesh = true;
      mesh.isPickable = false;
      part.setEnabled(false);
      this.exactParts.push({ mesh, first: at, count: n });
      at += n;
    }
    this.exactBody = this.exactParts[0].mesh;
    this._sig.fill(NaN);
    this.update();
  }

  _updateExactBody() {
    const P = this.avatar.posedGltfVertices(this._exactPositions);
    for (const { mesh, first, count } of this.exactParts) {
      mesh.updateVerticesData(this.B.VertexBuffer.PositionKind, P.subarray(3 * first, 3 * (first + count)), false, false);
    }
  }

  // The body node's meshes, one per primitive of the body mesh (the body's, then a garment's).
  get bodyParts() {
    const body = this.bodyNode;
    if (!body) return [];
    return body.getVerticesData ? [body] : body.getChildMeshes(true).filter((m) => m.getVerticesData);
  }

  // World-space Gaussian centres (N x 3) after update().
  worldMeans(out = new Float64Array(3 * this.avatar.N)) {
    const e = this.root ? this.root.getWorldMatrix().m : [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
    return this.avatar.transformedMeans(e, out);
  }

  _project(camera) {
    const sub = this.mesh.subMeshes[0];
    if (!this.mesh.isEnabled()) return;
    this.update();
    const P = camera.getProjectionMatrix().m, V = camera.getViewMatrix().m;
    if (P[15] !== 0 || Math.abs(P[11]) !== 1) { sub.indexCount = 0; return; }  // perspective cameras only
    const engine = this.scene.getEngine();
    const vp = camera.viewport.toGlobal(engine.getRenderWidth(), engine.getRenderHeight());
    const W = vp.width, H = vp.height, s = -P[11];  // s = 1: right-handed (looks along -z), -1: left-handed
    const rootM = this.root ? this.root.getWorldMatrix().m : [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
    const E = mul(V, rootM, this._m2);  // avatar frame -> Babylon view space
    const cam = openCvFromGl(P, E, W, H, camera.minZ, s);
    cam.depthMargin = this.avatar.depthMargin;
    const n = this.splats.project(cam, this.avatar);
    this.texture.update(this.splats.data);
    this.material.setVector4('hahaViewport', new this.B.Vector4(vp.x, vp.y, W, H));
    sub.indexCount = 6 * n;
    this.visibleSplats = n;
  }

  dispose() {
    this.scene.onBeforeCameraRenderObservable.remove(this._beforeCamera);
    this.mesh.dispose();
    this.material.dispose();
    this.texture.dispose();
  }
}
