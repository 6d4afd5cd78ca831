// three.js GLTFLoader plugin for HAHA avatars (.glb + HAHA_gaussian_avatar, format/spec.md,
// versions 1 to 3): the loaded gltf.scene keeps the standard skinned, textured body that
// GLTFLoader makes, plus a HahaGaussianLayer: the face-bound Gaussians, reposed every frame
// from the skeleton's bones with the exact triangle-bound maths of the haha loader (linear
// blend skinning with every influence and the embedded pose correctives, face frames of the
// posed mesh; ../avatar.js) and splatted like `haha render` (3DGS EWA, sorted by depth, hidden
// behind the mesh by the depth buffer; ../splat.js). Bones driven by an AnimationMixer or set
// by hand (bone.quaternion) move the Gaussians with the body.
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
import { SplatProjector, STRIDE } from '../splat.js';

export const EXTENSION_NAME = 'HAHA_gaussian_avatar';
const TEX_SPLATS_PER_ROW = 512;  // 4 RGBA32F texels per splat

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
    let body = byNode.get(ext.body.node);
    if (body && !body.isSkinnedMesh) body = body.getObjectByProperty('isSkinnedMesh', true);
    if (!body || !body.isSkinnedMesh) throw new Error(`${name}: ${EXTENSION_NAME}: body node ${ext.body.node} is not a skinned mesh in the loaded scene`);
    if (body.skeleton.bones.length !== NUM_JOINTS) throw new Error(`${name}: skin: must have exactly ${NUM_JOINTS} joints (SMPL-X)`);
    if (ext.splats && this.options.hideSplatPrimitive !== false) {
      const s = byNode.get(ext.splats.node);
      if (s) s.visible = false;
    }
    const layer = new HahaGaussianLayer(avatar, body, this.options);
    result.scene.add(layer);
    result.userData.hahaAvatar = layer;
  }
}

const SPLAT_VS = /* glsl */ `
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D splats;  // 4 texels per splat: rect | mean, conic.ab | conic.c, opacity, power_min, z | colour, ndc z
uniform vec4 hahaViewport; // x, y, width, height (pixels)
flat out vec2 vMean;
flat out vec3 vConic;
flat out vec2 vParams;
flat out vec3 vColor;
void main() {
  int s = gl_VertexID / 4, corner = gl_VertexID % 4;
  ivec2 b = ivec2((s % ${TEX_SPLATS_PER_ROW}) * 4, s / ${TEX_SPLATS_PER_ROW});
  vec4 t0 = texelFetch(splats, b, 0), t1 = texelFetch(splats, b + ivec2(1, 0), 0);
  vec4 t2 = texelFetch(splats, b + ivec2(2, 0), 0), t3 = texelFetch(splats, b + ivec2(3, 0), 0);
  vec2 pix = mix(t0.xy, t0.zw, vec2(float(corner & 1), float(corner >> 1)));
  gl_Position = vec4(2.0 * pix.x / hahaViewport.z - 1.0, 1.0 - 2.0 * pix.y / hahaViewport.w, t3.w, 1.0);
  vMean = t1.xy;
  vConic = vec3(t1.zw, t2.x);
  vParams = t2.yz;
  vColor = t3.rgb;
}`;

// libhaha/render/gaussian_kernels.h pixel_alpha; premultiplied "over" blending back to front
// gives the same sum as the rasterizer's front-to-back compositing.
const SPLAT_FS = /* glsl */ `
precision highp float;
uniform vec4 hahaViewport;
flat in vec2 vMean;
flat in vec3 vConic;
flat in vec2 vParams;
flat in vec3 vColor;
out vec4 hahaColor;
void main() {
  vec2 d = vec2(gl_FragCoord.x - hahaViewport.x, hahaViewport.w - (gl_FragCoord.y - hahaViewport.y)) - vMean;
  float power = -0.5 * (vConic.x * d.x * d.x + vConic.z * d.y * d.y) - vConic.y * d.x * d.y;
  if (power < vParams.y) discard;
  float alpha = min(0.99, vParams.x * exp(power));
  if (alpha < 1.0 / 255.0) discard;
  // Colours are display-referred like the texture: to linear, then to the output space.
  vec4 c = linearToOutputTexel(sRGBTransferEOTF(vec4(vColor, 1.0)));
  hahaColor = vec4(c.rgb * alpha, alpha);
}`;

// The Gaussian layer: a child of gltf.scene (its frame is the avatar's glTF frame). update()
// reposes from the bones (run automatically when the world matrices are updated and before
// each render); the splats are projected for each camera that renders it.
export class HahaGaussianLayer extends THREE.Mesh {
  constructor(avatar, skinnedMesh, options = {}) {
    const N = avatar.N;
    const rows = Math.max(1, Math.ceil(N / TEX_SPLATS_PER_ROW));
    const data = new Float32Array(4 * 4 * TEX_SPLATS_PER_ROW * rows);
    const texture = new THREE.DataTexture(data, 4 * TEX_SPLATS_PER_ROW, rows, THREE.RGBAFormat, THREE.FloatType);
    texture.minFilter = texture.magFilter = THREE.NearestFilter;
    texture.generateMipmaps = false;
    texture.needsUpdate = true;
    const geometry = new THREE.BufferGeometry();
    const index = new Uint32Array(6 * Math.max(1, N));
    for (let i = 0; i < N; i++) index.set([4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 2, 4 * i + 1, 4 * i + 3], 6 * i);
    geometry.setIndex(new THREE.BufferAttribute(index, 1));
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(4 * Math.max(1, N)), 1));  // unused: gl_VertexID
    geometry.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    geometry.setDrawRange(0, 0);
    const material = new THREE.ShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: SPLAT_VS, fragmentShader: SPLAT_FS,
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
    this.bones = skinnedMesh.skeleton.bones;
    this.projector = new SplatProjector(N);
    this.splatData = data;
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
    const e = this.matrixWorld.elements, m = this.avatar.means;
    for (let i = 0; i < this.avatar.N; i++) {
      const x = m[3 * i], y = m[3 * i + 1], z = m[3 * i + 2];
      for (let r = 0; r < 3; r++) out[3 * i + r] = e[r] * x + e[4 + r] * y + e[8 + r] * z + e[12 + r];
    }
    return out;
  }

  onBeforeRender(renderer, scene, camera) {
    this.update();
    const cam = this._openCvCamera(renderer, camera);
    const mat = this.material, a = this.avatar;
    if (!cam) { this.geometry.setDrawRange(0, 0); return; }
    cam.depthMargin = a.depthMargin;
    const n = this.projector.project(cam, a.N, a.means, a.quats, a.scales, a.gOpacity, a.gColor, { corners: 0 });
    this.projector.write(this.splatData, n, true);
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
    return {
      width: W, height: H,
      fx: P[0] * W / 2, fy: P[5] * H / 2, cx: (1 - P[8]) * W / 2, cy: (1 + P[9]) * H / 2,
      R: [E[0], E[4], E[8], -E[1], -E[5], -E[9], -E[2], -E[6], -E[10]],
      t: [E[12], -E[13], -E[14]],
      near: P[14] / (P[10] - 1), far: Infinity, depthA: P[10], depthB: P[14],
    };
  }

  // exactBody: the body drawn from the CPU-posed vertices (every influence, pose correctives)
  // instead of GPU skinning; the SkinnedMesh is hidden.
  _makeExactBody() {
    const sk = this.skinnedMesh, a = this.avatar;
    const g = new THREE.BufferGeometry();
    if (sk.geometry.index) g.setIndex(sk.geometry.index);
    for (const k of ['uv', 'normal']) if (sk.geometry.attributes[k]) g.setAttribute(k, sk.geometry.attributes[k]);
    if (sk.geometry.attributes.position.count !== a.Vg) throw new Error(`${EXTENSION_NAME}: the body mesh has ${sk.geometry.attributes.position.count} vertices, the avatar ${a.Vg}`);
    this._exactPositions = new THREE.BufferAttribute(new Float32Array(3 * a.Vg), 3);
    this._exactPositions.setUsage(THREE.DynamicDrawUsage);
    g.setAttribute('position', this._exactPositions);
    g.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    const mesh = new THREE.Mesh(g, sk.material);
    mesh.name = 'HAHA_exact_body';
    mesh.frustumCulled = false;
    sk.visible = false;
    this.exactBody = mesh;
    this.add(mesh);
  }

  _updateExactBody() {
    const a = this.avatar, P = this._exactPositions.array, bv = a.bodyVertex;
    for (let g = 0; g < a.Vg; g++) {
      const s = 3 * bv[g];
      P[3 * g] = a.posed[s]; P[3 * g + 1] = a.posed[s + 1]; P[3 * g + 2] = a.posed[s + 2];
    }
    this._exactPositions.needsUpdate = true;
  }
}
