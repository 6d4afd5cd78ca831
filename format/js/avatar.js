// A HAHA avatar (.glb + HAHA_gaussian_avatar, format/spec.md, versions 1 to 4) decoded in
// JavaScript, and its reposing, written to match the C++ loader (format/avatar_unpack.cpp,
// format/avatar_loader.cpp, body/lbs.cpp, body/face_frames.h) step by step, in float64:
//
//   body mesh:     Draco (KHR_draco_mesh_compression) or, version 3, plain accessors (any
//                  layout glTF allows: byteStride, normalized integers, no indices);
//                  version 4: a garment's primitive 1 appended to primitive 0
//   rest vertices: the body mesh's first glTF vertex of each body vertex (_BODY_VERTEX;
//                  versions 1-2: the private Draco attribute BODY_VERTEX)
//   weights:       all JOINTS_n / WEIGHTS_n sets summed per body vertex; version 1-2
//                  quantized weights renormalised (version 3 codes sum to one exactly)
//   mesh coverage: COLOR_0 alpha per body vertex (white, alike on seam duplicates) with the
//                  material's alphaMode MASK at 0.5, or none (meshCoverage null)
//   joints:        regressed from the rest vertices (sparse jointRegressor), or, in version-2
//                  files without one, minus the inverse bind matrices' translations
//   faces:         gaussians.faceOrder "canonical" (version 3): the faces sorted into the
//                  canonical order (canonicalFaceOrder); "file": edgebreaker meshes list faces
//                  in the encoder's order with rotated corners. Either way a face carrying
//                  Gaussians is turned back by FACE_CORNER
//   LBS:           v' = sum_j w_j A_j (v + pose correctives) + transl, A_j = G_j [I | -J_j]
//   face frames:   T, R = [e | n | e x n], k = (|v0 - v2| + h) / 2 / scaleDivisor, with the
//                  degenerate-triangle rules of body/face_frames.h
//   Gaussians:     mu' = k R mu + T, r' = q(R) * r (Hamilton, q(R) Shepperd with w >= 0),
//                  s' = k s
//
// Nothing here touches three.js: the Draco decoder is passed in (decode(bytes, ids, types)
// -> { name: TypedArray }), so the maths can be run anywhere.
import { Glb } from './glb.js';

export const NUM_JOINTS = 55;
export const VERSION = 4, OLDEST_VERSION = 1;  // format versions this reader implements
// extensionsRequired entries a file may list (as format/avatar_unpack.cpp accepts them).
const SUPPORTED_REQUIRED = new Set(['KHR_draco_mesh_compression', 'EXT_texture_webp', 'KHR_materials_unlit', 'HAHA_gaussian_avatar']);
const ARRAY_OF = { 5120: 'Int8Array', 5121: 'Uint8Array', 5122: 'Int16Array', 5123: 'Uint16Array', 5125: 'Uint32Array', 5126: 'Float32Array' };
const FULL_SCALE = { 5120: 127, 5121: 255, 5122: 32767, 5123: 65535 };
export const MESH_COVERAGE_CUTOFF = 0.5;  // kCoverageCutoff: the mesh draws where coverage >= this
export const NUM_POSE_FEATURES = 486;
const EXT = 'HAHA_gaussian_avatar';
const ZERO3 = [0, 0, 0];
const DEGENERATE_REL = 1e-6, TINY = 1e-20;  // body/face_frames.h kFaceDegenerateRel, kFaceTiny
const FRAME = 17;                              // doubles per face frame: t(3) R(9) k q(4)
const RODRIGUES_TAYLOR_S = 1e-4;               // below: series (rotation.h); any small value works in double

// Compact pose correctives (format/pose_correctives_codec.h): a Draco point cloud of kept
// (joint, vertex) blocks with `rank` coefficients per coordinate, and float32 mixing rows
// (54, rank, 9); expanded to dense posedirs with the C++ decoder's sums (float64 in k order,
// rounded to float32).
async function decodeSparseLowRank(glb, pc, V, decode, fail) {
  const R = pc.rank, count = pc.count;
  if (!(Number.isInteger(R) && R >= 1 && R <= 9)) fail('body.poseCorrectives.rank: must be in 1..9');
  if (!(Number.isInteger(count) && count >= 0)) fail('body.poseCorrectives.count: bad value');
  const mb = glb.checkedView(pc.mixingBufferView, pc.mixingCrc32, 'body.poseCorrectives mixing rows');
  if (mb.byteLength !== (NUM_JOINTS - 1) * R * 9 * 4) fail('body.poseCorrectives: wrong mixing-row byte length');
  const mdv = new DataView(mb.buffer, mb.byteOffset, mb.byteLength);
  const mix = new Float32Array((NUM_JOINTS - 1) * R * 9);
  for (let i = 0; i < mix.length; i++) {
    mix[i] = mdv.getFloat32(4 * i, true);
    if (!Number.isFinite(mix[i])) fail('body.poseCorrectives: non-finite mixing row');
  }
  const pd = new Float32Array(V * 3 * NUM_POSE_FEATURES);
  if (count === 0) return pd;
  const bytes = glb.checkedView(pc.bufferView, pc.crc32, 'body.poseCorrectives');
  const names = ['JOINT', 'VERTEX', 'COEF_X', 'COEF_Y', 'COEF_Z'];
  const ids = {}, types = {};
  for (const k of names) {
    ids[k] = pc.attributes[k];
    types[k] = k === 'JOINT' || k === 'VERTEX' ? 'Int32Array' : 'Float32Array';
  }
  const d = await decode(bytes, ids, types);
  if (d.JOINT.length !== count) fail(`body.poseCorrectives: Draco stream has ${d.JOINT.length} points, the file says ${count}`);
  const coef = [d.COEF_X, d.COEF_Y, d.COEF_Z];
  let prev = -1;
  for (let p = 0; p < count; p++) {
    const j = d.JOINT[p], v = d.VERTEX[p];
    if (j < 1 || j > NUM_JOINTS - 1) fail(`body.poseCorrectives: joint ${j} out of range [1, 54]`);
    if (v < 0 || v >= V) fail(`body.poseCorrectives: vertex ${v} out of range [0, ${V})`);
    const key = j * V + v;
    if (key <= prev) fail('body.poseCorrectives: (joint, vertex) pairs not in strictly increasing order');
    prev = key;
    const m = (j - 1) * R * 9;
    for (let c = 0; c < 3; c++) {
      const cr = coef[c], base = (3 * v + c) * NUM_POSE_FEATURES + 9 * (j - 1);
      for (let k = 0; k < R; k++) if (!Number.isFinite(cr[p * R + k])) fail('body.poseCorrectives: non-finite coefficient');
      for (let s = 0; s < 9; s++) {
        let acc = 0;
        for (let k = 0; k < R; k++) acc += cr[p * R + k] * mix[m + k * 9 + s];
        pd[base + s] = Math.fround(acc);
      }
    }
  }
  return pd;
}

// The Gaussians' rotations (N x 4, w x y z, float32) from the decoded attributes g:
// "smallest3" (three components and the index of the largest) or "wxyz"; quantized ones
// back to unit length.
function gaussianRotations(g, jg, N, fail) {
  const smallest3 = jg.rotationEncoding === 'smallest3', gbits = jg.quantizationBits || {};
  const rot = new Float32Array(4 * N);
  if (smallest3) {
    const r3 = g.ROTATION, L = g.ROTATION_LARGEST;
    for (let i = 0; i < N; i++) {
      const l = L[i];
      if (l < 0 || l > 3) fail(`gaussians: ROTATION_LARGEST ${l} out of range`);
      let s2 = 0;
      for (let k = 0, o = 0; k < 4; k++) {
        if (k === l) continue;
        rot[4 * i + k] = r3[3 * i + o++];
        s2 += rot[4 * i + k] * rot[4 * i + k];
      }
      rot[4 * i + l] = Math.sqrt(Math.max(0, 1 - s2));
    }
  } else {
    rot.set(g.ROTATION);
  }
  if (gbits.ROTATION > 0) {  // quantized: back to unit length
    for (let i = 0; i < N; i++) {
      const q = rot.subarray(4 * i, 4 * i + 4);
      const n = Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(n > 1e-6)) fail(`gaussians: zero rotation at Gaussian ${i}`);
      for (let k = 0; k < 4; k++) q[k] = q[k] / n;
    }
  }
  return rot;
}

// The body mesh's primitives as one mesh (the body's, then a garment's): arrays appended,
// each primitive's indices shifted past the glTF vertices before it.
function concatPrimitives(parts) {
  const cat = (arrays) => {
    const out = new arrays[0].constructor(arrays.reduce((n, a) => n + a.length, 0));
    let at = 0;
    for (const a of arrays) { out.set(a, at); at += a.length; }
    return out;
  };
  const index = cat(parts.map((p) => Int32Array.from(p.index)));
  let at = 0, shift = 0;
  for (const p of parts) {
    for (let i = 0; i < p.index.length; i++) index[at + i] += shift;
    at += p.index.length;
    shift += p.source.length;
  }
  const sets = parts[0].joints.length;
  const joints = [], weights = [];
  for (let s = 0; s < sets; s++) {
    joints.push(cat(parts.map((p) => Int32Array.from(p.joints[s]))));
    weights.push(cat(parts.map((p) => Float32Array.from(p.weights[s]))));
  }
  return {
    pos: cat(parts.map((p) => Float32Array.from(p.pos))), uv: cat(parts.map((p) => Float32Array.from(p.uv))),
    source: cat(parts.map((p) => Int32Array.from(p.source))), index, joints, weights,
    edgebreaker: parts.some((p) => p.edgebreaker),
    color: parts[0].color ? cat(parts.map((p) => Float32Array.from(p.color))) : null,
  };
}

// COLOR_0 holds the mesh coverage in its alpha: VEC4 of float or normalized unsigned byte /
// short (the colour types glTF allows).
function checkColorAccessor(acc, fail) {
  if (!acc) fail('body mesh: attribute COLOR_0 has no accessor');
  if (acc.type !== 'VEC4') fail(`body mesh: COLOR_0: type ${acc.type}, expected VEC4 (the mesh coverage is its alpha)`);
  const ct = acc.componentType;
  if (!(ct === 5126 || ((ct === 5121 || ct === 5123) && acc.normalized === true))) {
    fail(`body mesh: COLOR_0: componentType ${ct} (glTF colours are float or normalized unsigned byte / short)`);
  }
}

export class Avatar {
  static async load(buffer, decode, name = 'avatar.glb') {
    const a = new Avatar();
    await a._load(buffer, decode, name);
    return a;
  }

  // glb: a Glb (glb.js) or an ArrayBuffer of the whole file. The steps below, in the order of
  // the C++ loader (format/avatar_unpack.cpp), each check where it was.
  async _load(buffer, decode, name) {
    const glb = buffer instanceof Glb ? buffer : new Glb(buffer, name);
    const fail = (m) => { throw new Error(`${glb.name}: ${m}`); };
    const sets = this._readExtension(glb, fail);
    const m = await this._readBodyMesh(sets, decode, fail);
    this._readRestVerticesAndFaces(m, fail);
    this._readMeshCoverage(m, fail);
    this._readSkinWeights(m, sets, fail);
    const skin = this._readSkeleton(fail);
    this._readRestJoints(skin, fail);
    await this._readPoseCorrectives(decode, fail);
    await this._readGaussians(m, decode, fail);
    this._readTexture();
    this._allocateScratch();
  }

  // The extension object: version, required extensions, body counts, face-frame divisor and
  // depth margin. Returns the number of skin sets.
  _readExtension(glb, fail) {
    const root = glb.json;
    const ext = root.extensions && root.extensions[EXT];
    if (!ext) fail(`not a HAHA avatar: the glTF has no ${EXT} extension`);
    if (!Number.isInteger(ext.version) || ext.version < OLDEST_VERSION || ext.version > VERSION) {
      fail(`${EXT}: unsupported version ${JSON.stringify(ext.version)} (this reader reads versions ${OLDEST_VERSION} to ${VERSION})`);
    }
    for (const e of root.extensionsRequired || []) {
      if (!SUPPORTED_REQUIRED.has(e)) fail(`requires glTF extension ${e}, which this reader does not support`);
    }
    this.glb = glb;
    this.ext = ext;
    this.version = ext.version;
    const jb = ext.body;
    if (!jb || typeof jb !== 'object') fail(`${EXT}.body: missing`);
    const V = jb.vertexCount, F = jb.faceCount, sets = jb.skinSets;
    if (!(Number.isInteger(V) && V >= 1) || !(Number.isInteger(F) && F >= 1)) fail(`${EXT}.body: bad vertexCount / faceCount`);
    if (!(Number.isInteger(sets) && sets >= 1 && sets <= 14)) fail(`${EXT}.body.skinSets: must be in 1..14`);
    this.V = V;
    this.F = F;
    if (!ext.faceFrame || !(ext.faceFrame.scaleDivisor > 0)) fail(`${EXT}.faceFrame.scaleDivisor: missing or not positive`);
    this.divisor = ext.faceFrame.scaleDivisor;
    this.depthMargin = ext.depthTest ? ext.depthTest.margin : 0;
    return sets;
  }

  // --- body mesh: Draco (any version) or plain accessors (version 3) ---
  // Its primitives are one mesh: primitive 0's triangles, then a garment's (primitive 1,
  // version 4, its Draco stream named by body.garment.draco).
  async _readBodyMesh(sets, decode, fail) {
    const glb = this.glb, root = glb.json, ext = this.ext, jb = ext.body;
    const mesh = (root.meshes || [])[jb.mesh];
    if (!mesh || !mesh.primitives || !mesh.primitives.length) fail(`body mesh ${jb.mesh}: missing or without primitives`);
    const prims = mesh.primitives;
    if (prims.length > 2) fail(`body mesh: ${prims.length} primitives (the body and at most a garment)`);
    if (prims.length > 1 && (!jb.garment || ext.version < 4)) fail(`body mesh: a second primitive, but no ${EXT}.body.garment (version 4)`);
    const parts = [];
    this.meshRewritten = false;
    for (let p = 0; p < prims.length; p++) {
      const prim = prims[p];
      if (prim.mode !== undefined && prim.mode !== 4) fail(`body mesh: not a triangle list (mode ${prim.mode})`);
      const kd = prim.extensions && prim.extensions.KHR_draco_mesh_compression;
      const jd = p === 0 ? jb.draco : jb.garment.draco;  // absent: a plain mesh, or a mesh rewritten by a tool
      if (ext.version < 3 && (!kd || !jd)) fail('body mesh: not Draco-compressed (KHR_draco_mesh_compression missing)');
      if (kd && !jd) this.meshRewritten = true;
      parts.push(kd ? await this._dracoBody(glb, prim, kd, jd, sets, decode, fail) : this._plainBody(glb, prim, sets, fail));
      if (p === 0) this.meshDraco = !!kd;
      if (p > 0 && !parts[0].color !== !parts[p].color) fail('body mesh: COLOR_0 on some body mesh primitives but not on all');
    }
    return parts.length === 1 ? parts[0] : concatPrimitives(parts);
  }

  // The rest vertices (the first glTF vertex of each body vertex) and the faces as body
  // vertices, from the decoded body mesh m.
  _readRestVerticesAndFaces(m, fail) {
    const V = this.V, F = this.F;
    const src = m.source, pos = m.pos;
    const Vg = src.length;
    if (m.index.length !== 3 * F) fail(`body mesh: ${m.index.length / 3} faces, the file says ${F}`);
    if (Vg < V) fail('body mesh: fewer glTF vertices than body vertices');
    this.Vg = Vg;
    this.bodyVertex = src;                  // glTF vertex -> body vertex
    this.gltfFaces = Int32Array.from(m.index);  // (F, 3) glTF vertex indices (= UV faces)
    this.uv = m.uv;                         // (Vg, 2) glTF UVs (v down)
    const rest = new Float64Array(3 * V);
    const seen = new Uint8Array(V);
    for (let g = 0; g < Vg; g++) {
      const s = src[g];
      if (!(s >= 0 && s < V)) fail(`body mesh: _BODY_VERTEX ${s} out of range [0, ${V})`);
      if (!seen[s]) {
        seen[s] = 1;
        rest[3 * s] = pos[3 * g]; rest[3 * s + 1] = pos[3 * g + 1]; rest[3 * s + 2] = pos[3 * g + 2];
      }
    }
    for (let v = 0; v < V; v++) if (!seen[v]) fail(`body mesh: body vertex ${v} has no glTF vertex`);
    this.rest = rest;
    const faces = new Int32Array(3 * F);
    for (let c = 0; c < 3 * F; c++) faces[c] = src[this.gltfFaces[c]];
    this.faces = faces;                     // (F, 3) body vertex indices (in the Gaussians' face order, below)
  }

  // --- mesh coverage, as avatar_unpack.cpp mesh_coverage(): COLOR_0 alpha per body vertex ---
  // this.meshCoverage: Float32Array (V) in [0, 1], or null (the whole mesh draws). The
  // material must cut where the coverage does (alphaMode MASK, alphaCutoff 0.5), and only then.
  _readMeshCoverage(m, fail) {
    const root = this.glb.json, prims = root.meshes[this.ext.body.mesh].primitives;
    let mask = null;
    for (const p of prims) {
      if (p.material === undefined) continue;
      const mat = (root.materials || [])[p.material];
      if (!mat) fail(`body mesh: material ${p.material} does not exist`);
      if (mat.alphaMode !== 'MASK') continue;
      const cutoff = mat.alphaCutoff === undefined ? 0.5 : mat.alphaCutoff;  // glTF's default
      if (cutoff !== MESH_COVERAGE_CUTOFF) fail(`materials[${p.material}].alphaCutoff: ${cutoff}, the mesh coverage cuts at ${MESH_COVERAGE_CUTOFF}`);
      mask = `materials[${p.material}]`;
    }
    this.meshCoverage = null;
    if (!m.color) {
      if (mask) fail(`${mask}: alphaMode MASK, but the body mesh has no COLOR_0 (the mesh coverage)`);
      return;
    }
    if (!mask) fail('body mesh: COLOR_0 (the mesh coverage) without its material\'s alphaMode MASK');
    const V = this.V, Vg = this.Vg, src = m.source, c = m.color;
    if (c.length !== 4 * Vg) fail('body mesh: COLOR_0 does not cover every glTF vertex');
    const cov = new Float32Array(V).fill(-1);
    for (let g = 0; g < Vg; g++) {
      const v = src[g], a = c[4 * g + 3];
      if (c[4 * g] !== 1 || c[4 * g + 1] !== 1 || c[4 * g + 2] !== 1) {
        fail(`body mesh: COLOR_0 of body vertex ${v} is not white (only its alpha, the mesh coverage, may vary)`);
      }
      if (!(a >= 0 && a <= 1)) fail(`body mesh: COLOR_0 alpha of body vertex ${v} is not in [0, 1]`);
      if (cov[v] >= 0 && cov[v] !== Math.fround(a)) fail(`body mesh: COLOR_0 alpha of body vertex ${v} differs between its glTF vertices (seam duplicates)`);
      cov[v] = a;
    }
    this.meshCoverage = cov;
  }

  // --- skinning weights, as avatar_unpack.cpp skin_weights(): dense per vertex, sparse here ---
  _readSkinWeights(m, sets, fail) {
    const ext = this.ext, jd = ext.body.draco, V = this.V, Vg = this.Vg, src = m.source;
    // Versions 1-2 stored Draco-quantized float weights whose sums are off by up to ~1e-3:
    // renormalised. Version 3 weights sum to one exactly (normalized integer codes).
    const bitsW = jd && jd.quantizationBits ? jd.quantizationBits.WEIGHTS : 0;
    const renormalise = ext.version < 3 && bitsW > 0;
    const wOff = new Int32Array(V + 1), wJ = [], wW = [];
    const dense = new Float64Array(NUM_JOINTS);
    const firstG = new Int32Array(V).fill(-1);
    for (let g = 0; g < Vg; g++) if (firstG[src[g]] < 0) firstG[src[g]] = g;
    for (let v = 0; v < V; v++) {
      const g = firstG[v];
      dense.fill(0);
      let sum = 0;
      for (let s = 0; s < sets; s++) {
        const J = m.joints[s], W = m.weights[s];
        for (let k = 0; k < 4; k++) {
          const j = J[4 * g + k], w = W[4 * g + k];
          if (!(j >= 0 && j < NUM_JOINTS)) fail(`body mesh: JOINTS_${s} index ${j} out of range`);
          if (!Number.isFinite(w) || w < -1e-3) fail(`body mesh: invalid skinning weight at vertex ${v}`);
          if (w !== 0) dense[j] = Math.fround(dense[j] + w);  // float accumulation, as C++
          sum += w;
        }
      }
      if (renormalise && !(sum > 0)) fail(`body mesh: vertex ${v} has no skinning weight`);
      for (let j = 0; j < NUM_JOINTS; j++) {
        let w = dense[j];
        if (renormalise) w = w > 0 ? Math.fround(w / sum) : 0;
        if (w !== 0) { wJ.push(j); wW.push(w); }
      }
      wOff[v + 1] = wJ.length;
    }
    this.wOff = wOff;
    this.wJ = Int32Array.from(wJ);
    this.wW = Float64Array.from(wW);
  }

  // --- skeleton: parents from the skin's node tree (returns the skin) ---
  _readSkeleton(fail) {
    const root = this.glb.json, jb = this.ext.body;
    const skin = (root.skins || [])[jb.skin];
    if (!skin || !Array.isArray(skin.joints)) fail(`skin ${jb.skin}: missing`);
    const nodeParent = new Int32Array(root.nodes.length).fill(-1);
    root.nodes.forEach((n, i) => (n.children || []).forEach((c) => { nodeParent[c] = i; }));
    this.jointNodes = skin.joints.slice();
    if (this.jointNodes.length !== NUM_JOINTS) fail('skin: must have exactly 55 joints (SMPL-X)');
    this.parents = this.jointNodes.map((n) => this.jointNodes.indexOf(nodeParent[n]));
    for (let j = 1; j < NUM_JOINTS; j++) if (this.parents[j] < 0 || this.parents[j] >= j) fail('skin: joints not in parent-first order');
    return skin;
  }

  // --- rest joints: regressed from the rest vertices, or stored in the inverse bind matrices ---
  _readRestJoints(skin, fail) {
    const glb = this.glb, root = glb.json, ext = this.ext, jb = ext.body, rest = this.rest;
    const J = new Float64Array(3 * NUM_JOINTS);
    const jr = jb.jointRegressor;
    if (jr) {
      const jrb = glb.checkedView(jr.bufferView, jr.crc32, 'body.jointRegressor');
      const nnz = jr.count;
      const jrv = new DataView(jrb.buffer, jrb.byteOffset, jrb.byteLength);
      for (let i = 0; i < nnz; i++) {
        const j = jrv.getInt32(4 * i, true), v = jrv.getInt32(4 * nnz + 4 * i, true), w = jrv.getFloat32(8 * nnz + 4 * i, true);
        for (let c = 0; c < 3; c++) J[3 * j + c] += w * rest[3 * v + c];
      }
    } else {
      if (ext.version < 2) fail('body.jointRegressor: missing');
      const acc = (root.accessors || [])[skin.inverseBindMatrices];
      if (!acc || acc.type !== 'MAT4' || acc.componentType !== 5126 || acc.count !== NUM_JOINTS) fail('skin.inverseBindMatrices: must be 55 float MAT4');
      const ib = glb.readAccessor(skin.inverseBindMatrices, 16, 'skin.inverseBindMatrices').values;
      for (let j = 0; j < NUM_JOINTS; j++) for (let c = 0; c < 3; c++) J[3 * j + c] = -ib[16 * j + 12 + c];
    }
    this.restJoints = J;
  }

  // --- optional pose correctives (V, 3, 486): dense, or "sparse_lowrank" ---
  async _readPoseCorrectives(decode, fail) {
    const glb = this.glb, jb = this.ext.body, V = this.V;
    this.posedirs = null;
    if (jb.poseCorrectives && jb.poseCorrectives.encoding === 'sparse_lowrank') {
      this.posedirs = await decodeSparseLowRank(glb, jb.poseCorrectives, V, decode, fail);
    } else if (jb.poseCorrectives) {
      const pc = jb.poseCorrectives;
      if (pc.encoding !== undefined && pc.encoding !== 'dense') fail(`body.poseCorrectives: unknown encoding ${pc.encoding}`);
      const bytes = glb.checkedView(pc.bufferView, pc.crc32, 'body.poseCorrectives');
      const n = V * 3 * NUM_POSE_FEATURES;
      const pd = new Float32Array(n);
      const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
      if (pc.componentType === 'float32') {
        for (let i = 0; i < n; i++) pd[i] = dv.getFloat32(4 * i, true);
      } else {
        const sb = glb.checkedView(pc.scaleBufferView, pc.scaleCrc32, 'body.poseCorrectives scale');
        const sdv = new DataView(sb.buffer, sb.byteOffset, sb.byteLength);
        const scale = new Float32Array(NUM_POSE_FEATURES);
        for (let f = 0; f < NUM_POSE_FEATURES; f++) scale[f] = sdv.getFloat32(4 * f, true);
        for (let i = 0; i < n; i++) pd[i] = Math.fround(dv.getInt16(2 * i, true) * scale[i % NUM_POSE_FEATURES]);
      }
      this.posedirs = pd;
    }
    this.trainedWithPoseCorrectives = !!jb.trainedWithPoseCorrectives;
  }

  // --- Gaussians: Draco point cloud, GENERIC attributes by unique id ---
  async _readGaussians(m, decode, fail) {
    const jg = this.ext.gaussians;
    if (!jg || typeof jg !== 'object') fail(`${EXT}.gaussians: missing`);
    const N = jg.count;
    if (!(Number.isInteger(N) && N >= 0)) fail(`${EXT}.gaussians.count: bad value`);
    this.N = N;
    const fileOrder = this._readGaussianFaceOrder(fail);
    if (!fileOrder) canonicalFaceOrder(this.faces, this.gltfFaces);
    const cornerStored = !fileOrder || m.edgebreaker;
    if (N > 0) {
      const g = await this._decodeGaussians(cornerStored, decode, fail);
      if (cornerStored) this._turnFacesToStoredCorners(g, fail);
      // Float32 arrays, as the C++ loader keeps them.
      const gbits = jg.quantizationBits || {};
      const rot = gaussianRotations(g, jg, N, fail);
      const scale = new Float32Array(g.SCALE);
      if (jg.scaleEncoding === 'log') for (let i = 0; i < scale.length; i++) scale[i] = Math.exp(scale[i]);
      else if (jg.scaleEncoding !== 'linear') fail(`gaussians: unknown scaleEncoding ${jg.scaleEncoding}`);
      const opacity = new Float32Array(g.OPACITY);
      if (gbits.OPACITY > 0) for (let i = 0; i < N; i++) opacity[i] = Math.min(1, Math.max(0, opacity[i]));
      this.gFace = g.FACE;
      this.gOffset = g.OFFSET;
      this.gRot = rot;
      this.gScale = scale;
      this.gColor = g.COLOR;
      this.gOpacity = opacity;
    } else {
      this.gFace = new Int32Array(0);
      this.gOffset = this.gScale = this.gColor = this.gOpacity = this.gRot = new Float32Array(0);
    }
  }

  // Which face order FACE indexes: true for the file's faces ("file", versions 1-2, lossless
  // packs), false for the canonical order (version 3), which survives tools that rewrite the mesh.
  _readGaussianFaceOrder(fail) {
    const ext = this.ext, jd = ext.body.draco, jg = ext.gaussians;
    let fileOrder = ext.version < 3;
    if (jg.faceOrder !== undefined) {
      if (jg.faceOrder !== 'file' && jg.faceOrder !== 'canonical') fail(`gaussians.faceOrder: unknown '${jg.faceOrder}'`);
      if (jg.faceOrder === 'canonical' && ext.version < 3) fail(`gaussians.faceOrder: 'canonical' is not in version ${ext.version}`);
      fileOrder = jg.faceOrder === 'file';
    } else if (ext.version >= 3) {
      fail('gaussians.faceOrder: missing');
    }
    if (fileOrder && (!jd || this.meshRewritten)) {
      fail(`gaussians.faceOrder: the Gaussians name faces in the file's order, but the mesh was rewritten (no ${EXT}.body.draco)`);
    }
    this.faceOrder = fileOrder ? 'file' : 'canonical';
    return fileOrder;
  }

  // The Gaussians of every stream (one point cloud, or tiers), concatenated: { FACE, OFFSET,
  // ROTATION, (ROTATION_LARGEST), SCALE, COLOR, OPACITY, (FACE_CORNER) }, faces checked.
  async _decodeGaussians(cornerStored, decode, fail) {
    const glb = this.glb, jg = this.ext.gaussians, ga = jg.attributes, N = this.N, F = this.F;
    // One point cloud, or importance tiers (haha pack --lod): the viewer reads them all.
    if (jg.tiers && !Array.isArray(jg.tiers)) fail('gaussians.tiers: not an array');
    const streams = jg.tiers ? jg.tiers.map((t, i) => glb.checkedView(t.bufferView, t.crc32, `gaussians tier ${i}`))
                             : [glb.checkedView(jg.bufferView, jg.crc32, 'gaussians')];
    const smallest3 = jg.rotationEncoding === 'smallest3';
    if (!smallest3 && jg.rotationEncoding !== 'wxyz') fail(`gaussians: unknown rotationEncoding ${jg.rotationEncoding}`);
    const gids = { FACE: ga.FACE, OFFSET: ga.OFFSET, ROTATION: ga.ROTATION, SCALE: ga.SCALE, COLOR: ga.COLOR, OPACITY: ga.OPACITY };
    const gtypes = { FACE: 'Int32Array', OFFSET: 'Float32Array', ROTATION: 'Float32Array', SCALE: 'Float32Array', COLOR: 'Float32Array', OPACITY: 'Float32Array' };
    if (smallest3) { gids.ROTATION_LARGEST = ga.ROTATION_LARGEST; gtypes.ROTATION_LARGEST = 'Int32Array'; }
    if (cornerStored) { gids.FACE_CORNER = ga.FACE_CORNER; gtypes.FACE_CORNER = 'Int32Array'; }
    for (const k of Object.keys(gids)) if (!Number.isInteger(gids[k])) fail(`gaussians.attributes.${k}: missing`);
    const parts = [];
    for (const bytes of streams) parts.push(await decode(bytes, gids, gtypes));
    const g = {};
    for (const key of Object.keys(gtypes)) {
      const total = parts.reduce((n, p) => n + p[key].length, 0);
      g[key] = new (parts[0][key].constructor)(total);
      let at = 0;
      for (const p of parts) { g[key].set(p[key], at); at += p[key].length; }
    }
    if (g.FACE.length !== N) fail(`gaussians: Draco stream has ${g.FACE.length} points, the file says ${N}`);
    for (let i = 0; i < N; i++) if (g.FACE[i] < 0 || g.FACE[i] >= F) fail(`gaussians: Gaussian ${i} refers to face ${g.FACE[i]}`);
    return g;
  }

  // Turns each Gaussian-carrying face (faces and gltfFaces) so that its corner 0 is the
  // body's (FACE_CORNER).
  _turnFacesToStoredCorners(g, fail) {
    const N = this.N, F = this.F;
    const done = new Int8Array(F).fill(-1);
    for (let i = 0; i < N; i++) {
      const f = g.FACE[i], r = g.FACE_CORNER[i];
      if (r < 0 || r > 2) fail(`gaussians: FACE_CORNER ${r} out of range`);
      if (done[f] >= 0) { if (done[f] !== r) fail(`gaussians: Gaussians on face ${f} disagree on FACE_CORNER`); continue; }
      done[f] = r;
      for (const arr of [this.faces, this.gltfFaces]) {
        const c = [arr[3 * f], arr[3 * f + 1], arr[3 * f + 2]];
        for (let k = 0; k < 3; k++) arr[3 * f + k] = c[(k + r) % 3];
      }
    }
  }

  // --- texture: the exact float copy (lossless packs) or the image ---
  _readTexture() {
    const glb = this.glb, root = glb.json, jt = this.ext.texture;
    const img = root.images[jt.image];
    this.textureMime = img.mimeType;
    this.textureBytes = glb.checkedView(img.bufferView, jt.crc32, 'texture');
    this.textureExact = null;
    if (jt.exact) {
      const b = glb.checkedView(jt.exact.bufferView, jt.exact.crc32, 'texture.exact');
      this.textureExact = { width: jt.exact.width, height: jt.exact.height, data: new Float32Array(b.slice().buffer) };
    }
  }

  // Scratch of repose().
  _allocateScratch() {
    const V = this.V, N = this.N, F = this.F;
    this.posed = new Float64Array(3 * V);
    this.skinA = new Float64Array(12 * NUM_JOINTS);
    this.means = new Float64Array(3 * N);
    this.quats = new Float64Array(4 * N);
    this.scales = new Float64Array(3 * N);
    this.frames = new Float64Array(FRAME * F);  // t(3) R(9, row-major) k(1) q(R)(4)
  }

  // The KHR_draco_mesh_compression stream: { pos, uv, source, index, joints[s], weights[s],
  // edgebreaker } (weights decoded to float as the accessor says: float, or normalized ints).
  async _dracoBody(glb, prim, kd, jd, sets, decode, fail) {
    let bytes;
    if (jd) {
      if (jd.bufferView !== kd.bufferView) fail(`${EXT}.body.draco: bufferView differs from the primitive's Draco stream`);
      bytes = glb.checkedView(jd.bufferView, jd.crc32, 'body.draco');
    } else {
      bytes = glb.view(kd.bufferView);  // rewritten by a tool: no checksum
    }
    // Draco header: "DRACO", major, minor, encoder type (1 = mesh), method (0 sequential, 1 edgebreaker).
    if (bytes.length < 9 || String.fromCharCode(...bytes.subarray(0, 5)) !== 'DRACO') fail('body mesh: not a Draco stream');
    if (bytes[7] !== 1) fail('body mesh: the Draco stream is not a triangle mesh');
    const edgebreaker = bytes[8] === 1;
    if (edgebreaker && this.version < 2) fail('body mesh: edgebreaker-encoded, which version 1 files never are');
    if (jd && jd.method !== undefined && jd.method !== (edgebreaker ? 'edgebreaker' : 'sequential')) {
      fail(`${EXT}.body.draco.method: says '${jd.method}' but the Draco stream is ${edgebreaker ? 'edgebreaker' : 'sequential'}`);
    }
    const da = kd.attributes || {};
    const accessorOf = (name) => {
      const a = (glb.json.accessors || [])[(prim.attributes || {})[name]];
      if (!a) fail(`body mesh: attribute ${name} has no accessor`);
      return a;
    };
    const ids = {}, types = {}, norm = {};
    const want = (key, id, type) => {
      if (!Number.isInteger(id)) fail(`body mesh: no Draco attribute id for ${key}`);
      ids[key] = id;
      types[key] = type;
    };
    want('POSITION', da.POSITION, 'Float32Array');
    const uvAcc = accessorOf('TEXCOORD_0');
    want('TEXCOORD_0', da.TEXCOORD_0, uvAcc.componentType === 5126 ? 'Float32Array' : ARRAY_OF[uvAcc.componentType]);
    if (uvAcc.normalized) norm.TEXCOORD_0 = FULL_SCALE[uvAcc.componentType];
    if (this.version < 3) want('BODY_VERTEX', jd.attributes && jd.attributes.BODY_VERTEX, 'Int32Array');
    else want('BODY_VERTEX', da._BODY_VERTEX, 'Int32Array');
    for (let s = 0; s < sets; s++) {
      want(`JOINTS_${s}`, da[`JOINTS_${s}`], 'Int32Array');
      const wa = accessorOf(`WEIGHTS_${s}`);
      if (wa.componentType === 5126) {
        want(`WEIGHTS_${s}`, da[`WEIGHTS_${s}`], 'Float32Array');
      } else if (wa.componentType === 5121 || wa.componentType === 5123) {
        want(`WEIGHTS_${s}`, da[`WEIGHTS_${s}`], ARRAY_OF[wa.componentType]);
        norm[`WEIGHTS_${s}`] = FULL_SCALE[wa.componentType];
      } else {
        fail(`WEIGHTS_${s} accessor: componentType ${wa.componentType} is not a glTF weight type`);
      }
    }
    const hasColor = (prim.attributes || {}).COLOR_0 !== undefined;
    if (hasColor) {
      const ca = accessorOf('COLOR_0');
      checkColorAccessor(ca, fail);
      want('COLOR_0', da.COLOR_0, ARRAY_OF[ca.componentType]);
      if (ca.normalized) norm.COLOR_0 = FULL_SCALE[ca.componentType];
    }
    const d = await decode(bytes, ids, types);
    if (!d.index) fail('body mesh: the Draco stream has no faces');
    const Vg = d.BODY_VERTEX.length;
    for (const k of Object.keys(ids)) {
      const comps = k === 'POSITION' ? 3 : k === 'TEXCOORD_0' ? 2 : k === 'BODY_VERTEX' ? 1 : 4;
      if (d[k].length !== comps * Vg) fail(`body mesh: Draco attribute ${k} has ${d[k].length} values, expected ${comps * Vg}`);
    }
    const toFloat = (k) => {
      if (!norm[k]) return d[k];
      const out = new Float32Array(d[k].length);
      for (let i = 0; i < out.length; i++) out[i] = d[k][i] / norm[k];
      return out;
    };
    const joints = [], weights = [];
    for (let s = 0; s < sets; s++) { joints.push(d[`JOINTS_${s}`]); weights.push(toFloat(`WEIGHTS_${s}`)); }
    const color = hasColor ? toFloat('COLOR_0') : null;
    return { pos: d.POSITION, uv: toFloat('TEXCOORD_0'), source: d.BODY_VERTEX, index: d.index, joints, weights, edgebreaker, color };
  }

  // Plain accessors (version 3; any layout glTF allows, e.g. as rewritten by tools).
  _plainBody(glb, prim, sets, fail) {
    const attrs = prim.attributes || {};
    const read = (name, comps) => {
      if (!Number.isInteger(attrs[name])) fail(`body mesh: attribute ${name} missing`);
      return glb.readAccessor(attrs[name], comps, `body mesh ${name}`);
    };
    const pos = read('POSITION', 3);
    const Vg = pos.count;
    const same = (a, name) => {
      if (a.count !== Vg) fail(`body mesh: ${name} has ${a.count} values, POSITION ${Vg}`);
      return a;
    };
    const integers = (a, name) => {
      const out = new Int32Array(a.values.length);
      for (let i = 0; i < out.length; i++) {
        const x = a.values[i];
        if (x !== Math.floor(x) || !(Math.abs(x) < 1e9)) fail(`body mesh: ${name} holds a non-integer value`);
        out[i] = x;
      }
      return out;
    };
    const p = Float32Array.from(pos.values);
    for (let i = 0; i < p.length; i++) if (!Number.isFinite(p[i])) fail(`body mesh: non-finite POSITION at vertex ${Math.floor(i / 3)}`);
    const uv = Float32Array.from(same(read('TEXCOORD_0', 2), 'TEXCOORD_0').values);
    const source = integers(same(read('_BODY_VERTEX', 1), '_BODY_VERTEX'), '_BODY_VERTEX');
    const joints = [], weights = [];
    for (let s = 0; s < sets; s++) {
      joints.push(integers(same(read(`JOINTS_${s}`, 4), `JOINTS_${s}`), `JOINTS_${s}`));
      weights.push(Float32Array.from(same(read(`WEIGHTS_${s}`, 4), `WEIGHTS_${s}`).values));
    }
    let index;
    if (prim.indices !== undefined) {
      const ia = glb.readAccessor(prim.indices, 1, 'body mesh indices');
      index = integers(ia, 'indices');
      for (let i = 0; i < index.length; i++) if (!(index[i] >= 0 && index[i] < Vg)) fail(`body mesh: index ${index[i]} out of range`);
    } else {
      index = new Int32Array(Vg);
      for (let i = 0; i < Vg; i++) index[i] = i;
    }
    if (index.length % 3) fail('body mesh: index count is not a multiple of 3');
    let color = null;
    if (attrs.COLOR_0 !== undefined) {
      checkColorAccessor((glb.json.accessors || [])[attrs.COLOR_0], fail);
      color = Float32Array.from(same(read('COLOR_0', 4), 'COLOR_0').values);
    }
    return { pos: p, uv, source, index, joints, weights, edgebreaker: false, color };
  }

  // Skinning matrices A_j (3 x 4, row-major) of a pose (165 axis-angle values).
  skinning(pose) {
    const A = this.skinA, J = this.restJoints, par = this.parents;
    const world = new Float64Array(12 * NUM_JOINTS);  // rotation (9) + translation (3)
    const feat = new Float64Array(NUM_POSE_FEATURES);
    for (let j = 0; j < NUM_JOINTS; j++) {
      const R = rodrigues(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
      if (j > 0) for (let r = 0; r < 3; r++) for (let s = 0; s < 3; s++) feat[9 * (j - 1) + 3 * r + s] = R[3 * r + s] - (r === s ? 1 : 0);
      const w = world.subarray(12 * j, 12 * j + 12);
      if (j === 0) {
        w.set(R, 0);
        w[9] = J[0]; w[10] = J[1]; w[11] = J[2];
      } else {
        const p = world.subarray(12 * par[j], 12 * par[j] + 12);
        const d = [J[3 * j] - J[3 * par[j]], J[3 * j + 1] - J[3 * par[j] + 1], J[3 * j + 2] - J[3 * par[j] + 2]];
        for (let r = 0; r < 3; r++) {
          for (let s = 0; s < 3; s++) w[3 * r + s] = p[3 * r] * R[s] + p[3 * r + 1] * R[3 + s] + p[3 * r + 2] * R[6 + s];
          w[9 + r] = p[3 * r] * d[0] + p[3 * r + 1] * d[1] + p[3 * r + 2] * d[2] + p[9 + r];
        }
      }
      // A_j = [W.R | W.t - W.R J_j]
      for (let r = 0; r < 3; r++) {
        A[12 * j + 4 * r] = w[3 * r]; A[12 * j + 4 * r + 1] = w[3 * r + 1]; A[12 * j + 4 * r + 2] = w[3 * r + 2];
        A[12 * j + 4 * r + 3] = w[9 + r] - (w[3 * r] * J[3 * j] + w[3 * r + 1] * J[3 * j + 1] + w[3 * r + 2] * J[3 * j + 2]);
      }
    }
    return { A, feat, world };
  }

  // Posed body vertices (body order) into this.posed; returns the joints' world transforms.
  reposeBody(pose, transl) {
    const { A, feat, world } = this.skinning(pose);
    this.reposeBodyWith(A, feat, transl);
    return world;
  }

  // Posed body vertices from skinning matrices A (55 x 3 x 4, row-major, v' = A_j v) and the
  // pose-corrective features feat (486: R_j - I of joints 1..54, row-major 3 x 3 each; null:
  // none), e.g. from an engine's skeleton (skinningFromBones). transl is added.
  reposeBodyWith(A, feat, transl = ZERO3) {
    const V = this.V, rest = this.rest, out = this.posed, off = this.wOff, wJ = this.wJ, wW = this.wW;
    let vp = rest;
    if (this.posedirs && feat) {
      vp = this._vposed || (this._vposed = new Float64Array(3 * V));
      vp.set(rest);
      const nz = [];
      for (let f = 0; f < NUM_POSE_FEATURES; f++) if (feat[f] !== 0) nz.push(f);
      const pd = this.posedirs;
      for (let i = 0; i < 3 * V; i++) {
        const base = i * NUM_POSE_FEATURES;
        let acc = 0;
        for (let k = 0; k < nz.length; k++) acc += pd[base + nz[k]] * feat[nz[k]];
        vp[i] += acc;
      }
    }
    const T = new Float64Array(12);
    for (let v = 0; v < V; v++) {
      T.fill(0);
      for (let e = off[v]; e < off[v + 1]; e++) {
        const w = wW[e], a = 12 * wJ[e];
        for (let k = 0; k < 12; k++) T[k] += w * A[a + k];
      }
      const x = vp[3 * v], y = vp[3 * v + 1], z = vp[3 * v + 2];
      out[3 * v] = T[0] * x + T[1] * y + T[2] * z + T[3] + transl[0];
      out[3 * v + 1] = T[4] * x + T[5] * y + T[6] * z + T[7] + transl[1];
      out[3 * v + 2] = T[8] * x + T[9] * y + T[10] * z + T[11] + transl[2];
    }
  }

  // Skinning matrices and pose-corrective features of an engine's skeleton. jointToAvatar(j):
  // joint j's 4 x 4 skinning matrix in the avatar's glTF frame (column-major 16 numbers:
  // world(joint) * inverseBind(joint), expressed relative to the avatar's root), and
  // localRotation(j): the joint's rotation relative to its parent, a unit quaternion
  // [x, y, z, w]. Returns { A, feat } for reposeBodyWith.
  skinningFromMatrices(jointToAvatar, localRotation) {
    const A = this._boneA || (this._boneA = new Float64Array(12 * NUM_JOINTS));
    const feat = this._boneFeat || (this._boneFeat = new Float64Array(NUM_POSE_FEATURES));
    for (let j = 0; j < NUM_JOINTS; j++) {
      const e = jointToAvatar(j);
      for (let r = 0; r < 3; r++) for (let c = 0; c < 4; c++) A[12 * j + 4 * r + c] = e[4 * c + r];
      if (j === 0) continue;
      const [x, y, z, w] = localRotation(j);
      const R = [
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
      ];
      for (let k = 0; k < 9; k++) feat[9 * (j - 1) + k] = R[k] - (k % 4 === 0 ? 1 : 0);
    }
    return { A, feat };
  }

  // World-space Gaussians of the posed body in this.posed: means, quats (w, x, y, z), scales.
  poseGaussians() {
    const N = this.N, P = this.posed, faces = this.faces, fr = this.frames, div = this.divisor;
    const need = this._needFrame || (this._needFrame = (() => {
      const s = new Uint8Array(this.F);
      for (let i = 0; i < N; i++) s[this.gFace[i]] = 1;
      return s;
    })());
    for (let f = 0; f < this.F; f++) if (need[f]) faceFrame(P, faces[3 * f], faces[3 * f + 1], faces[3 * f + 2], div, fr, FRAME * f);
    const mo = this.gOffset, ro = this.gRot, so = this.gScale;
    for (let i = 0; i < N; i++) {
      const b = FRAME * this.gFace[i];
      const k = fr[b + 12];
      const mx = mo[3 * i], my = mo[3 * i + 1], mz = mo[3 * i + 2];
      for (let r = 0; r < 3; r++) {
        this.means[3 * i + r] = k * (fr[b + 3 + 3 * r] * mx + fr[b + 4 + 3 * r] * my + fr[b + 5 + 3 * r] * mz) + fr[b + r];
        this.scales[3 * i + r] = k * so[3 * i + r];
      }
      // q(R) * r (Hamilton)
      const q0 = fr[b + 13], q1 = fr[b + 14], q2 = fr[b + 15], q3 = fr[b + 16];
      const w2 = ro[4 * i], x2 = ro[4 * i + 1], y2 = ro[4 * i + 2], z2 = ro[4 * i + 3];
      this.quats[4 * i] = q0 * w2 - q1 * x2 - q2 * y2 - q3 * z2;
      this.quats[4 * i + 1] = q0 * x2 + q1 * w2 + q2 * z2 - q3 * y2;
      this.quats[4 * i + 2] = q0 * y2 - q1 * z2 + q2 * w2 + q3 * x2;
      this.quats[4 * i + 3] = q0 * z2 + q1 * y2 - q2 * x2 + q3 * w2;
    }
  }

  // The posed body (this.posed) per glTF vertex (Vg x 3: its body vertex's position) into
  // out, e.g. an engine's position buffer.
  posedGltfVertices(out) {
    const P = this.posed, bv = this.bodyVertex;
    for (let g = 0; g < this.Vg; g++) {
      const s = 3 * bv[g];
      out[3 * g] = P[s]; out[3 * g + 1] = P[s + 1]; out[3 * g + 2] = P[s + 2];
    }
    return out;
  }

  // The posed Gaussian centres (this.means) mapped by a column-major 4 x 4 matrix e (e.g. the
  // avatar frame's world matrix) into out (N x 3).
  transformedMeans(e, out = new Float64Array(3 * this.N)) {
    const m = this.means;
    for (let i = 0; i < this.N; i++) {
      const x = m[3 * i], y = m[3 * i + 1], z = m[3 * i + 2];
      for (let r = 0; r < 3; r++) out[3 * i + r] = e[r] * x + e[4 + r] * y + e[8 + r] * z + e[12 + r];
    }
    return out;
  }

  // One frame: posed vertices + world Gaussians.
  repose(pose, transl) {
    const world = this.reposeBody(pose, transl);
    this.poseGaussians();
    return world;
  }
}

// Axis-angle -> row-major 3 x 3 (body/rotation.h rodrigues: R = I + a K + b K^2).
export function rodrigues(wx, wy, wz) {
  const s = wx * wx + wy * wy + wz * wz;
  let a, b;
  if (s < RODRIGUES_TAYLOR_S) {
    a = 1 + s * (-1 / 6 + s * (1 / 120 + s * (-1 / 5040 + s * (1 / 362880 + s * (-1 / 39916800)))));
    b = 0.5 + s * (-1 / 24 + s * (1 / 720 + s * (-1 / 40320 + s * (1 / 3628800 + s * (-1 / 479001600)))));
  } else {
    const t = Math.sqrt(s), half = Math.sin(t / 2);
    a = Math.sin(t) / t;
    b = (2 * half * half) / s;
  }
  // K = skew(w), K^2 = w w^T - s I
  return [
    1 + b * (wx * wx - s), -a * wz + b * wx * wy, a * wy + b * wx * wz,
    a * wz + b * wx * wy, 1 + b * (wy * wy - s), -a * wx + b * wy * wz,
    -a * wy + b * wx * wz, a * wx + b * wy * wz, 1 + b * (wz * wz - s),
  ];
}

// Shepperd's method, w >= 0 (core/math.h mat_to_quat). Arguments row-major.
export function matToQuat(m00, m01, m02, m10, m11, m12, m20, m21, m22) {
  const tr = m00 + m11 + m22;
  let q;
  if (tr > m00 && tr > m11 && tr > m22) {
    const s = Math.sqrt(tr + 1) * 2;
    q = [s / 4, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s];
  } else if (m00 > m11 && m00 > m22) {
    const s = Math.sqrt(1 + m00 - m11 - m22) * 2;
    q = [(m21 - m12) / s, s / 4, (m01 + m10) / s, (m02 + m20) / s];
  } else if (m11 > m22) {
    const s = Math.sqrt(1 + m11 - m00 - m22) * 2;
    q = [(m02 - m20) / s, (m01 + m10) / s, s / 4, (m12 + m21) / s];
  } else {
    const s = Math.sqrt(1 + m22 - m00 - m11) * 2;
    q = [(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, s / 4];
  }
  if (q[0] < 0) for (let k = 0; k < 4; k++) q[k] = -q[k];
  return q;
}

// Face frame of the triangle (i0, i1, i2) of P into out[o..o+17): t (3), R row-major (9), k,
// q(R) (w, x, y, z).
// body/face_frames.h face_frame(), including its degenerate-triangle rules.
export function faceFrame(P, i0, i1, i2, divisor, out, o) {
  const v0x = P[3 * i0], v0y = P[3 * i0 + 1], v0z = P[3 * i0 + 2];
  const v1x = P[3 * i1], v1y = P[3 * i1 + 1], v1z = P[3 * i1 + 2];
  const v2x = P[3 * i2], v2y = P[3 * i2 + 1], v2z = P[3 * i2 + 2];
  const ax = v2x - v1x, ay = v2y - v1y, az = v2z - v1z;        // a = v2 - v1
  const bx = v0x - v1x, by = v0y - v1y, bz = v0z - v1z;        // b0 = v0 - v1
  const dx = v0x - v2x, dy = v0y - v2y, dz = v0z - v2z;        // d02 = v0 - v2
  const la = Math.hypot(ax, ay, az), lb = Math.hypot(bx, by, bz), ld = Math.hypot(dx, dy, dz);
  const thr = DEGENERATE_REL * (la + lb + ld) + TINY;
  let ex = 1, ey = 0, ez = 0;
  if (la > thr) { ex = ax / la; ey = ay / la; ez = az / la; }
  let cx = ey * bz - ez * by, cy = ez * bx - ex * bz, cz = ex * by - ey * bx;  // c = e x b0
  const lc = Math.hypot(cx, cy, cz);
  let nx, ny, nz;
  if (lc > thr) {
    nx = cx / lc; ny = cy / lc; nz = cz / lc;
  } else {  // any_perpendicular(e)
    const fx = Math.abs(ex), fy = Math.abs(ey), fz = Math.abs(ez);
    let px = 0, py = 0, pz = 0;
    if (fx <= fy && fx <= fz) px = 1; else if (fy <= fz) py = 1; else pz = 1;
    const qx = ey * pz - ez * py, qy = ez * px - ex * pz, qz = ex * py - ey * px;
    const lq = Math.hypot(qx, qy, qz);
    nx = qx / lq; ny = qy / lq; nz = qz / lq;
  }
  const crx = ay * bz - az * by, cry = az * bx - ax * bz, crz = ax * by - ay * bx;  // a x b0
  const area2 = Math.hypot(crx, cry, crz);
  const den = ld > thr ? ld : thr;
  const bbx = ey * nz - ez * ny, bby = ez * nx - ex * nz, bbz = ex * ny - ey * nx;  // e x n
  out[o] = (v0x + v1x + v2x) / 3; out[o + 1] = (v0y + v1y + v2y) / 3; out[o + 2] = (v0z + v1z + v2z) / 3;
  out[o + 3] = ex; out[o + 4] = nx; out[o + 5] = bbx;
  out[o + 6] = ey; out[o + 7] = ny; out[o + 8] = bby;
  out[o + 9] = ez; out[o + 10] = nz; out[o + 11] = bbz;
  out[o + 12] = (ld + area2 / den) / (2 * divisor);
  const q = matToQuat(ex, nx, bbx, ey, ny, bby, ez, nz, bbz);
  out[o + 13] = q[0]; out[o + 14] = q[1]; out[o + 15] = q[2]; out[o + 16] = q[3];
}


// The canonical face order (format/spec.md, gaussians.faceOrder; format/canonical_faces.cpp):
// every face rotated to the lexicographically smallest of its three corner rotations
// (orientation kept), the faces sorted by that triple (stable). faces (F, 3) body vertices
// and uvFaces (F, 3) glTF vertices are reordered in place the same way.
export function canonicalFaceOrder(faces, uvFaces) {
  const F = faces.length / 3;
  const rot = new Uint8Array(F), key = new Int32Array(3 * F);
  const less = (a0, a1, a2, b0, b1, b2) => a0 !== b0 ? a0 < b0 : a1 !== b1 ? a1 < b1 : a2 < b2;
  for (let f = 0; f < F; f++) {
    const v = [faces[3 * f], faces[3 * f + 1], faces[3 * f + 2]];
    let best = 0;
    for (let r = 1; r < 3; r++) {
      if (less(v[r], v[(r + 1) % 3], v[(r + 2) % 3], v[best], v[(best + 1) % 3], v[(best + 2) % 3])) best = r;
    }
    rot[f] = best;
    for (let i = 0; i < 3; i++) key[3 * f + i] = v[(best + i) % 3];
  }
  const order = Array.from({ length: F }, (_, f) => f);
  order.sort((a, b) => {  // Array.prototype.sort is stable
    for (let i = 0; i < 3; i++) if (key[3 * a + i] !== key[3 * b + i]) return key[3 * a + i] - key[3 * b + i];
    return 0;
  });
  for (const arr of [faces, uvFaces]) {
    const src = arr.slice();
    for (let k = 0; k < F; k++) {
      const f = order[k], r = rot[f];
      for (let i = 0; i < 3; i++) arr[3 * k + i] = src[3 * f + (r + i) % 3];
    }
  }
  return order;
}
