// Babylon.js glTF loader extension for HAHA avatars (.glb + HAHA_gaussian_avatar,
// format/spec.md, versions 1 to 3): the loaded scene keeps Babylon's skinned, textured body
// and gets a Gaussian layer, reposed every frame from the skeleton's joint nodes with the
// exact triangle-bound maths of the haha loader (every skin influence, the embedded pose
// correctives, face frames of the posed mesh: ../avatar.js) and splatted like `haha render`
// (3DGS EWA, depth-sorted, hidden behind the body by the depth buffer: ../splat.js).
// Animation groups or hand-set rotations (node.rotationQuaternion) of the joints move it.
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
import { SplatProjector, STRIDE } from '../splat.js';

export const EXTENSION_NAME = 'HAHA_gaussian_avatar';
const TEX_SPLATS_PER_ROW = 512;  // 4 RGBA32F texels per splat

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

// GLSL in Babylon's dialect (its WebGL2 engine turns attribute / varying / gl_FragColor into
// GLSL ES 3.00).
const SPLAT_VS = `
precision highp float;
precision highp int;
attribute vec3 position;  // unused (gl_VertexID picks the splat and corner)
uniform highp sampler2D splats;
uniform vec4 hahaViewport;
flat varying vec2 vMean;
flat varying vec3 vConic;
flat varying vec2 vParams;
flat varying vec3 vColor;
void main() {
  int s = gl_VertexID / 4, corner = gl_VertexID % 4;
  ivec2 b = ivec2((s % ${TEX_SPLATS_PER_ROW}) * 4, s / ${TEX_SPLATS_PER_ROW});
  vec4 t0 = texelFetch(splats, b, 0), t1 = texelFetch(splats, b + ivec2(1, 0), 0);
  vec4 t2 = texelFetch(splats, b + ivec2(2, 0), 0), t3 = texelFetch(splats, b + ivec2(3, 0), 0);
  vec2 pix = mix(t0.xy, t0.zw, vec2(float(corner & 1), float(corner >> 1)));
  gl_Position = vec4(2.0 * pix.x / hahaViewport.z - 1.0, 1.0 - 2.0 * pix.y / hahaViewport.w, t3.w, 1.0 + 0.0 * position.x);
  vMean = t1.xy;
  vConic = vec3(t1.zw, t2.x);
  vParams = t2.yz;
  vColor = t3.rgb;
}`;

// Babylon draws display-referred colours (gamma space), as the Gaussians' colours are.
const SPLAT_FS = `
precision highp float;
uniform vec4 hahaViewport;
flat varying vec2 vMean;
flat varying vec3 vConic;
flat varying vec2 vParams;
flat varying vec3 vColor;
void main() {
  vec2 d = vec2(gl_FragCoord.x - hahaViewport.x, hahaViewport.w - (gl_FragCoord.y - hahaViewport.y)) - vMean;
  float power = -0.5 * (vConic.x * d.x * d.x + vConic.z * d.y * d.y) - vConic.y * d.x * d.y;
  if (power < vParams.y) discard;
  float alpha = min(0.99, vParams.x * exp(power));
  if (alpha < 1.0 / 255.0) discard;
  gl_FragColor = vec4(vColor * alpha, alpha);
}`;

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
    this.projector = new SplatProjector(N);
    const rows = Math.max(1, Math.ceil(N / TEX_SPLATS_PER_ROW));
    this.splatData = new Float32Array(4 * 4 * TEX_SPLATS_PER_ROW * rows);
    this.texture = B.RawTexture.CreateRGBATexture(this.splatData, 4 * TEX_SPLATS_PER_ROW, rows, scene, false, false,
      B.Constants.TEXTURE_NEAREST_SAMPLINGMODE, B.Constants.TEXTURETYPE_FLOAT);
    const mesh = new B.Mesh('HAHA_gaussians', scene);
    const positions = new Float32Array(3 * 4 * Math.max(1, N));
    const indices = new Uint32Array(6 * Math.max(1, N));
    for (let i = 0; i < N; i++) indices.set([4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 2, 4 * i + 1, 4 * i + 3], 6 * i);
    mesh.setVerticesData(B.VertexBuffer.PositionKind, positions, false);
    mesh.setIndices(indices, 4 * Math.max(1, N));
    mesh.alwaysSelectAsActiveMesh = true;
    mesh.isPickable = false;
    const material = new B.ShaderMaterial('HAHA_gaussians', scene, { vertexSource: SPLAT_VS, fragmentSource: SPLAT_FS }, {
      attributes: ['position'], uniforms: ['hahaViewport'], samplers: ['splats'], needAlphaBlending: true,
    });
    material.setTexture('splats', this.texture);
    material.backFaceCulling = false;
    material.disableDepthWrite = true;
    material.alphaMode = B.Constants.ALPHA_PREMULTIPLIED;
    material.depthFunction = B.Constants.LEQUAL;
    mesh.material = material;
    mesh.subMeshes[0].indexCount = 0;
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
  // instead of Babylon's GPU skinning; the skinned mesh is disabled.
  makeExactBody() {
    const B = this.B, body = this.bodyNode, a = this.avatar;
    if (!body || !body.getVerticesData) throw new Error(`${EXTENSION_NAME}: the body node is not a mesh`);
    if (body.getTotalVertices() !== a.Vg) throw new Error(`${EXTENSION_NAME}: the body mesh has ${body.getTotalVertices()} vertices, the avatar ${a.Vg}`);
    const mesh = new B.Mesh('HAHA_exact_body', this.scene);
    this._exactPositions = new Float32Array(3 * a.Vg);
    mesh.setVerticesData(B.VertexBuffer.PositionKind, this._exactPositions, true);
    const uv = body.getVerticesData(B.VertexBuffer.UVKind);
    if (uv) mesh.setVerticesData(B.VertexBuffer.UVKind, uv, false);
    mesh.setIndices(body.getIndices(), a.Vg);
    mesh.material = body.material;
    for (const k of ['sideOrientation', 'overrideMaterialSideOrientation']) if (k in body) mesh[k] = body[k];  // the loader's winding rule
    mesh.parent = this.root;  // positions are in the avatar's glTF frame
    mesh.alwaysSelectAsActiveMesh = true;
    mesh.isPickable = false;
    body.setEnabled(false);
    this.exactBody = mesh;
    this._sig.fill(NaN);
    this.update();
  }

  _updateExactBody() {
    const a = this.avatar, P = this._exactPositions, bv = a.bodyVertex;
    for (let g = 0; g < a.Vg; g++) {
      const s = 3 * bv[g];
      P[3 * g] = a.posed[s]; P[3 * g + 1] = a.posed[s + 1]; P[3 * g + 2] = a.posed[s + 2];
    }
    this.exactBody.updateVerticesData(this.B.VertexBuffer.PositionKind, P, false, false);
  }

  // World-space Gaussian centres (N x 3) after update().
  worldMeans(out = new Float64Array(3 * this.avatar.N)) {
    const e = this.root ? this.root.getWorldMatrix().m : [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
    const m = this.avatar.means;
    for (let i = 0; i < this.avatar.N; i++) {
      const x = m[3 * i], y = m[3 * i + 1], z = m[3 * i + 2];
      for (let r = 0; r < 3; r++) out[3 * i + r] = e[r] * x + e[4 + r] * y + e[8 + r] * z + e[12 + r];
    }
    return out;
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
    const a = this.avatar;
    const cam = {
      width: W, height: H,
      fx: P[0] * W / 2, fy: P[5] * H / 2, cx: (1 - s * P[8]) * W / 2, cy: (1 + s * P[9]) * H / 2,
      R: [E[0], E[4], E[8], -E[1], -E[5], -E[9], -s * E[2], -s * E[6], -s * E[10]],
      t: [E[12], -E[13], -s * E[14]],
      near: camera.minZ, far: Infinity, depthA: s * P[10], depthB: P[14], depthMargin: a.depthMargin,
    };
    const n = this.projector.project(cam, a.N, a.means, a.quats, a.scales, a.gOpacity, a.gColor, { corners: 0 });
    this.projector.write(this.splatData, n, true);
    this.texture.update(this.splatData);
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
