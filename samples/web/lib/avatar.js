// A HAHA avatar (.glb + HAHA_gaussian_avatar, format/spec.md) decoded in the browser, and
// its reposing, written to match the C++ loader (format/avatar_unpack.cpp,
// format/avatar_loader.cpp, body/lbs.cpp, body/face_frames.h) step by step, in float64:
//
//   rest vertices: the body mesh's first glTF vertex of each body vertex (BODY_VERTEX)
//   weights:       all JOINTS_n / WEIGHTS_n sets summed per body vertex, renormalised when
//                  the weights are quantized (negatives dropped), as the unpacker does
//   joints:        regressed from the rest vertices (sparse jointRegressor), or, in version-2
//                  files without one, minus the inverse bind matrices' translations
//   faces:         edgebreaker meshes (version 2) list faces in the encoder's order with
//                  rotated corners: a face carrying Gaussians is turned back by FACE_CORNER
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
export const NUM_POSE_FEATURES = 486;
const EXT = 'HAHA_gaussian_avatar';
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

export class Avatar {
  static async load(buffer, decode, name = 'avatar.glb') {
    const a = new Avatar();
    await a._load(buffer, decode, name);
    return a;
  }

  async _load(buffer, decode, name) {
    const glb = new Glb(buffer, name);
    const root = glb.json;
    const fail = (m) => { throw new Error(`${name}: ${m}`); };
    const ext = root.extensions && root.extensions[EXT];
    if (!ext) fail(`not a HAHA avatar: the glTF has no ${EXT} extension`);
    if (ext.version !== 1 && ext.version !== 2) fail(`${EXT}: unsupported version ${ext.version} (this viewer reads versions 1 and 2)`);
    this.glb = glb;
    this.ext = ext;
    const jb = ext.body;
    const V = jb.vertexCount, F = jb.faceCount;
    this.V = V;
    this.F = F;
    this.divisor = ext.faceFrame.scaleDivisor;
    this.depthMargin = ext.depthTest ? ext.depthTest.margin : 0;

    // --- body mesh (Draco: sequential keeps the body's face order, edgebreaker does not) ---
    const prim = root.meshes[jb.mesh].primitives[0];
    const kd = prim.extensions && prim.extensions.KHR_draco_mesh_compression;
    if (!kd) fail('body mesh: not Draco-compressed');
    const meshBytes = glb.checkedView(jb.draco.bufferView, jb.draco.crc32, 'body.draco');
    const ids = { POSITION: kd.attributes.POSITION, TEXCOORD_0: kd.attributes.TEXCOORD_0, BODY_VERTEX: jb.draco.attributes.BODY_VERTEX };
    const types = { POSITION: 'Float32Array', TEXCOORD_0: 'Float32Array', BODY_VERTEX: 'Int32Array' };
    const sets = jb.skinSets;
    for (let s = 0; s < sets; s++) {
      ids[`JOINTS_${s}`] = kd.attributes[`JOINTS_${s}`];
      types[`JOINTS_${s}`] = 'Int32Array';
      ids[`WEIGHTS_${s}`] = kd.attributes[`WEIGHTS_${s}`];
      types[`WEIGHTS_${s}`] = 'Float32Array';
    }
    const m = await decode(meshBytes, ids, types);
    const src = m.BODY_VERTEX, pos = m.POSITION;
    const Vg = src.length;
    if (m.index.length !== 3 * F) fail(`body mesh: ${m.index.length / 3} faces, the file says ${F}`);
    this.Vg = Vg;
    this.bodyVertex = src;                  // glTF vertex -> body vertex
    this.gltfFaces = m.index;               // (F, 3) glTF vertex indices (= UV faces)
    this.uv = m.TEXCOORD_0;                 // (Vg, 2) glTF UVs (v down)
    const rest = new Float64Array(3 * V);
    const seen = new Uint8Array(V);
    for (let g = 0; g < Vg; g++) {
      const s = src[g];
      if (s < 0 || s >= V) fail(`body mesh: BODY_VERTEX ${s} out of range`);
      if (!seen[s]) {
        seen[s] = 1;
        rest[3 * s] = pos[3 * g]; rest[3 * s + 1] = pos[3 * g + 1]; rest[3 * s + 2] = pos[3 * g + 2];
      }
    }
    for (let v = 0; v < V; v++) if (!seen[v]) fail(`body mesh: body vertex ${v} has no glTF vertex`);
    this.rest = rest;
    const faces = new Int32Array(3 * F);
    for (let c = 0; c < 3 * F; c++) faces[c] = src[m.index[c]];
    this.faces = faces;                     // (F, 3) body vertex indices

    // --- skinning weights, as avatar_unpack.cpp skin_weights(): dense per vertex, sparse here ---
    const quantW = jb.draco.quantizationBits && jb.draco.quantizationBits.WEIGHTS > 0;
    const wOff = new Int32Array(V + 1), wJ = [], wW = [];
    const dense = new Float64Array(NUM_JOINTS);
    const firstG = new Int32Array(V).fill(-1);
    for (let g = 0; g < Vg; g++) if (firstG[src[g]] < 0) firstG[src[g]] = g;
    for (let v = 0; v < V; v++) {
      const g = firstG[v];
      dense.fill(0);
      let sum = 0;
      for (let s = 0; s < sets; s++) {
        const J = m[`JOINTS_${s}`], W = m[`WEIGHTS_${s}`];
        for (let k = 0; k < 4; k++) {
          const j = J[4 * g + k], w = W[4 * g + k];
          if (j < 0 || j >= NUM_JOINTS) fail(`body mesh: JOINTS_${s} index ${j} out of range`);
          if (w !== 0) dense[j] += w;
          sum += w;
        }
      }
      for (let j = 0; j < NUM_JOINTS; j++) {
        let w = dense[j];
        if (quantW) w = w > 0 ? Math.fround(w / sum) : 0;
        if (w !== 0) { wJ.push(j); wW.push(w); }
      }
      wOff[v + 1] = wJ.length;
    }
    this.wOff = wOff;
    this.wJ = Int32Array.from(wJ);
    this.wW = Float64Array.from(wW);

    // --- skeleton: parents from the skin's node tree ---
    const skin = root.skins[jb.skin];
    const nodeParent = new Int32Array(root.nodes.length).fill(-1);
    root.nodes.forEach((n, i) => (n.children || []).forEach((c) => { nodeParent[c] = i; }));
    this.jointNodes = skin.joints.slice();
    if (this.jointNodes.length !== NUM_JOINTS) fail('skin: must have exactly 55 joints (SMPL-X)');
    this.parents = this.jointNodes.map((n) => this.jointNodes.indexOf(nodeParent[n]));
    for (let j = 1; j < NUM_JOINTS; j++) if (this.parents[j] < 0 || this.parents[j] >= j) fail('skin: joints not in parent-first order');

    // --- rest joints: regressed from the rest vertices, or stored in the inverse bind matrices ---
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
      const acc = root.accessors[skin.inverseBindMatrices];
      if (!acc || acc.type !== 'MAT4' || acc.componentType !== 5126 || acc.count !== NUM_JOINTS) fail('skin.inverseBindMatrices: must be 55 float MAT4');
      const ib = glb.view(acc.bufferView);
      const off = acc.byteOffset || 0;
      if (off + 64 * NUM_JOINTS > ib.byteLength) fail('skin.inverseBindMatrices: accessor runs past its bufferView');
      const dv = new DataView(ib.buffer, ib.byteOffset + off, 64 * NUM_JOINTS);
      for (let j = 0; j < NUM_JOINTS; j++) for (let c = 0; c < 3; c++) J[3 * j + c] = -dv.getFloat32(64 * j + 4 * (12 + c), true);
    }
    this.restJoints = J;

    // --- optional pose correctives (V, 3, 486): dense, or "sparse_lowrank" ---
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

    // --- Gaussians: Draco point cloud, GENERIC attributes by unique id ---
    const jg = ext.gaussians;
    const N = jg.count;
    this.N = N;
    const ga = jg.attributes;
    const gbits = jg.quantizationBits || {};
    if (N > 0) {
      // One point cloud, or importance tiers (haha pack --lod): the viewer reads them all.
      const streams = jg.tiers ? jg.tiers.map((t, i) => glb.checkedView(t.bufferView, t.crc32, `gaussians tier ${i}`))
                               : [glb.checkedView(jg.bufferView, jg.crc32, 'gaussians')];
      const smallest3 = jg.rotationEncoding === 'smallest3';
      if (!smallest3 && jg.rotationEncoding !== 'wxyz') fail(`gaussians: unknown rotationEncoding ${jg.rotationEncoding}`);
      const gids = { FACE: ga.FACE, OFFSET: ga.OFFSET, ROTATION: ga.ROTATION, SCALE: ga.SCALE, COLOR: ga.COLOR, OPACITY: ga.OPACITY };
      const gtypes = { FACE: 'Int32Array', OFFSET: 'Float32Array', ROTATION: 'Float32Array', SCALE: 'Float32Array', COLOR: 'Float32Array', OPACITY: 'Float32Array' };
      if (smallest3) { gids.ROTATION_LARGEST = ga.ROTATION_LARGEST; gtypes.ROTATION_LARGEST = 'Int32Array'; }
      const edgebreaker = jb.draco.method === 'edgebreaker';
      if (edgebreaker) { gids.FACE_CORNER = ga.FACE_CORNER; gtypes.FACE_CORNER = 'Int32Array'; }
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
      if (edgebreaker) {  // turn each Gaussian-carrying face so its corner 0 is the body's
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
      // Float32 arrays, as the C++ loader keeps them.
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

    // --- texture: the exact float copy (lossless packs) or the image ---
    const jt = ext.texture;
    const img = root.images[jt.image];
    this.textureMime = img.mimeType;
    this.textureBytes = glb.checkedView(img.bufferView, jt.crc32, 'texture');
    this.textureExact = null;
    if (jt.exact) {
      const b = glb.checkedView(jt.exact.bufferView, jt.exact.crc32, 'texture.exact');
      this.textureExact = { width: jt.exact.width, height: jt.exact.height, data: new Float32Array(b.slice().buffer) };
    }

    // Scratch of repose().
    this.posed = new Float64Array(3 * V);
    this.skinA = new Float64Array(12 * NUM_JOINTS);
    this.means = new Float64Array(3 * N);
    this.quats = new Float64Array(4 * N);
    this.scales = new Float64Array(3 * N);
    this.frames = new Float64Array(FRAME * F);  // t(3) R(9, row-major) k(1) q(R)(4)
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
    const V = this.V, rest = this.rest, out = this.posed, off = this.wOff, wJ = this.wJ, wW = this.wW;
    let vp = rest;
    if (this.posedirs) {
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
    return world;
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
