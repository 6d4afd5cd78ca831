#!/usr/bin/env node
// Node test of the engine-free reader (format/js/avatar.js; CTest `js_reader`): every pack
// variant of a tiny avatar loads, and rewritten copies of it, made here the way other tools
// write glTF (the body mesh as plain accessors: one interleaved bufferView with byteStride and
// byteOffsets, float or normalized-integer weights and UVs, no indices; the faces reordered and
// their corners rotated; body.draco dropped), repose to the same Gaussians as the original in
// a raised-arm pose. Bad files give one-line errors naming the file.
// Usage: reader_test.mjs --haha PATH [--work DIR] [--run-from DIR] [--keep]   Exit codes: 0 pass, 1 fail, 77 skip.
import fs from 'node:fs';
import path from 'node:path';
import { SKIP, jsRoot, parseArgs, runner, workDir, tinyRun, packVariants, loadAvatarNode, raisedArmPose } from './common.mjs';

const opts = parseArgs({}, ['keep']);
if (!fs.existsSync(path.join(jsRoot, 'node_modules', 'three'))) {
  console.log('SKIP js_reader: format/js/node_modules is missing: npm ci --prefix format/js');
  process.exit(SKIP);
}
if (!opts.haha) { console.error('reader_test: --haha PATH is required'); process.exit(1); }
const { Glb } = await import('../glb.js');
const work = workDir(opts, 'haha-js-reader-');
const run = runner(opts.haha);
const runDir = tinyRun(run, work, opts['run-from']);
const variants = packVariants(run, opts.haha, runDir, work);
let failed = false;
const fail = (m) => { console.log(`FAIL: ${m}`); failed = true; };

function readGlb(file) {
  const b = fs.readFileSync(file);
  return new Glb(b.buffer.slice(b.byteOffset, b.byteOffset + b.length), file);
}

function writeGlb(file, json, bin) {
  const pad = (n) => (4 - (n % 4)) % 4;
  const js = Buffer.from(JSON.stringify(json));
  const jsonChunk = Buffer.concat([js, Buffer.alloc(pad(js.length), 0x20)]);
  const binChunk = Buffer.concat([Buffer.from(bin), Buffer.alloc(pad(bin.length))]);
  const head = Buffer.alloc(12);
  head.writeUInt32LE(0x46546c67, 0); head.writeUInt32LE(2, 4);
  head.writeUInt32LE(12 + 8 + jsonChunk.length + 8 + binChunk.length, 8);
  const ch = (len, type) => { const h = Buffer.alloc(8); h.writeUInt32LE(len, 0); h.writeUInt32LE(type, 4); return h; };
  fs.writeFileSync(file, Buffer.concat([head, ch(jsonChunk.length, 0x4e4f534a), jsonChunk, ch(binChunk.length, 0x004e4942), binChunk]));
}

// A copy of the avatar whose body mesh is rewritten as plain accessors from the reader's own
// decoded arrays. style: { weights: 'float' | 'ushort' | 'ubyte', uv: 'float' | 'ushort',
// unindexed, shuffle }.
function rewrite(src, avatar, style, file) {
  const g = readGlb(src);
  const json = JSON.parse(JSON.stringify(g.json));
  const ext = json.extensions.HAHA_gaussian_avatar;
  const jb = ext.body, prim = json.meshes[jb.mesh].primitives[0];
  const sets = jb.skinSets, Vg0 = avatar.Vg;
  // Per glTF vertex data, from a reader that keeps them: positions and skin come from the
  // original accessors / Draco stream through a second decode.
  const m = avatar._rawMesh;
  let faces = Array.from(avatar._rawIndex);  // file order, as stored
  const F = faces.length / 3;
  // Unindexed: one vertex per face corner.
  const vtx = style.unindexed ? faces.slice() : Array.from({ length: Vg0 }, (_, i) => i);
  if (style.unindexed) faces = faces.map((_, i) => i);
  if (style.shuffle) {  // reverse the face order and rotate every face's corners by one
    const nf = [];
    for (let f = F - 1; f >= 0; f--) nf.push(faces[3 * f + 1], faces[3 * f + 2], faces[3 * f]);
    faces = nf;
  }
  const Vg = vtx.length;
  // One interleaved bufferView: POSITION f32x3 | TEXCOORD_0 | _BODY_VERTEX u32 | JOINTS_s u8x4 | WEIGHTS_s
  const uvSize = style.uv === 'float' ? 8 : 4, wSize = style.weights === 'float' ? 16 : style.weights === 'ushort' ? 8 : 4;
  const stride = 12 + uvSize + 4 + sets * (4 + wSize) + 4;  // + 4 bytes of padding nobody reads
  const buf = Buffer.alloc(stride * Vg);
  const offs = { POSITION: 0, TEXCOORD_0: 12, _BODY_VERTEX: 12 + uvSize };
  for (let s = 0; s < sets; s++) {
    offs[`JOINTS_${s}`] = 12 + uvSize + 4 + s * (4 + wSize);
    offs[`WEIGHTS_${s}`] = offs[`JOINTS_${s}`] + 4;
  }
  for (let i = 0; i < Vg; i++) {
    const gv = vtx[i], o = i * stride;
    for (let k = 0; k < 3; k++) buf.writeFloatLE(m.pos[3 * gv + k], o + 4 * k);
    for (let k = 0; k < 2; k++) {
      if (style.uv === 'float') buf.writeFloatLE(m.uv[2 * gv + k], o + 12 + 4 * k);
      else buf.writeUInt16LE(Math.round(m.uv[2 * gv + k] * 65535), o + 12 + 2 * k);
    }
    buf.writeUInt32LE(m.source[gv], o + offs._BODY_VERTEX);
    for (let s = 0; s < sets; s++) {
      for (let k = 0; k < 4; k++) {
        buf.writeUInt8(m.joints[s][4 * gv + k], o + offs[`JOINTS_${s}`] + k);
        const w = m.weights[s][4 * gv + k];
        const wo = o + offs[`WEIGHTS_${s}`];
        if (style.weights === 'float') buf.writeFloatLE(w, wo + 4 * k);
        else if (style.weights === 'ushort') buf.writeUInt16LE(Math.round(w * 65535), wo + 2 * k);
        else buf.writeUInt8(Math.round(w * 255), wo + k);
      }
    }
  }
  const bin = Buffer.from(g.bin);
  const base = bin.length + ((4 - (bin.length % 4)) % 4);
  const idx = Buffer.alloc(4 * faces.length);
  faces.forEach((v, i) => idx.writeUInt32LE(v, 4 * i));
  const idxBase = base + buf.length;
  const newBin = Buffer.concat([bin, Buffer.alloc(base - bin.length), buf, style.unindexed && !style.shuffle ? Buffer.alloc(0) : idx]);
  const bv = json.bufferViews.length;
  json.bufferViews.push({ buffer: 0, byteOffset: base, byteLength: buf.length, byteStride: stride, target: 34962 });
  const acc = (name, type, componentType, normalized, extra = {}) => {
    json.accessors.push({ bufferView: bv, byteOffset: offs[name], componentType, count: Vg, type, ...(normalized ? { normalized: true } : {}), ...extra });
    return json.accessors.length - 1;
  };
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < Vg; i++) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], m.pos[3 * vtx[i] + k]); hi[k] = Math.max(hi[k], m.pos[3 * vtx[i] + k]); }
  const attributes = {
    POSITION: acc('POSITION', 'VEC3', 5126, false, { min: lo.map(Math.fround), max: hi.map(Math.fround) }),
    TEXCOORD_0: style.uv === 'float' ? acc('TEXCOORD_0', 'VEC2', 5126, false) : acc('TEXCOORD_0', 'VEC2', 5123, true),
    _BODY_VERTEX: acc('_BODY_VERTEX', 'SCALAR', 5125, false),
  };
  const wType = { float: [5126, false], ushort: [5123, true], ubyte: [5121, true] }[style.weights];
  for (let s = 0; s < sets; s++) {
    attributes[`JOINTS_${s}`] = acc(`JOINTS_${s}`, 'VEC4', 5121, false);
    attributes[`WEIGHTS_${s}`] = acc(`WEIGHTS_${s}`, 'VEC4', wType[0], wType[1]);
  }
  const newPrim = { attributes, mode: 4, material: prim.material };
  if (!(style.unindexed && !style.shuffle)) {
    json.bufferViews.push({ buffer: 0, byteOffset: idxBase, byteLength: idx.length, target: 34963 });
    json.accessors.push({ bufferView: json.bufferViews.length - 1, componentType: 5125, count: faces.length, type: 'SCALAR' });
    newPrim.indices = json.accessors.length - 1;
  }
  json.meshes[jb.mesh].primitives[0] = newPrim;
  delete jb.draco;  // rewritten: no checksum of the mesh
  json.extensionsRequired = (json.extensionsRequired || []).filter((e) => e !== 'KHR_draco_mesh_compression');
  if (!json.extensionsRequired.length) delete json.extensionsRequired;
  json.buffers[0].byteLength = newBin.length + ((4 - (newBin.length % 4)) % 4);
  writeGlb(file, json, newBin);
}

const arm = raisedArmPose();
for (const v of variants) {
  // A reader instance that also keeps the raw per-glTF-vertex arrays (for rewriting).
  const { Avatar } = await import('../avatar.js');
  const orig = Avatar.prototype._dracoBody, origPlain = Avatar.prototype._plainBody;
  const keep = (m, a) => { a._rawMesh = m; a._rawIndex = Int32Array.from(m.index); return m; };
  Avatar.prototype._dracoBody = async function (...args) { return keep(await orig.apply(this, args), this); };
  Avatar.prototype._plainBody = function (...args) { return keep(origPlain.apply(this, args), this); };
  let a;
  try { a = await loadAvatarNode(v.file); } finally { Avatar.prototype._dracoBody = orig; Avatar.prototype._plainBody = origPlain; }
  a.repose(arm.pose, arm.transl);
  const ref = Float64Array.from(a.means), refQ = Float64Array.from(a.quats);
  console.log(`${v.name}: version ${a.version}, ${a.meshDraco ? 'Draco' : 'plain'} mesh, faceOrder ${a.faceOrder}, ${a.N} Gaussians, ${a.Vg} glTF vertices`);
  if (a.faceOrder !== 'canonical') {
    console.log(`  (faceOrder ${a.faceOrder}: the Gaussians name the file's faces, so a rewritten mesh is refused; checking that)`);
  }
  const styles = [
    { name: 'interleaved, float weights', weights: 'float', uv: 'float' },
    { name: 'interleaved, normalized ushort weights and UVs, faces reordered and rotated', weights: 'ushort', uv: 'ushort', shuffle: true },
    { name: 'no indices (one vertex per corner), normalized ubyte weights', weights: 'ubyte', uv: 'float', unindexed: true },
  ];
  for (const st of styles) {
    const out = `${work}/rewritten_${v.name}_${styles.indexOf(st)}.glb`;
    rewrite(v.file, a, st, out);
    let b;
    try {
      b = await loadAvatarNode(out);
    } catch (e) {
      if (a.faceOrder === 'file' && /faceOrder|not Draco-compressed/.test(e.message)) { console.log(`  ${st.name}: refused as expected: ${e.message}`); continue; }
      fail(`${st.name}: ${e.message}`);
      continue;
    }
    if (a.faceOrder === 'file') { fail(`${st.name}: a rewritten file-order mesh was accepted`); continue; }
    b.repose(arm.pose, arm.transl);
    let dm = 0, dq = 0;
    for (let i = 0; i < ref.length; i++) dm = Math.max(dm, Math.abs(b.means[i] - ref[i]));
    for (let i = 0; i < refQ.length / 4; i++) {  // q and -q are the same rotation
      let dm4 = 0, dp4 = 0;
      for (let k = 0; k < 4; k++) {
        dm4 += (b.quats[4 * i + k] - refQ[4 * i + k]) ** 2;
        dp4 += (b.quats[4 * i + k] + refQ[4 * i + k]) ** 2;
      }
      dq = Math.max(dq, Math.sqrt(Math.min(dm4, dp4)));
    }
    // ubyte weights are coarser (1/255): the posed centres move by up to about a millimetre.
    const tol = st.weights === 'ubyte' ? 5e-3 : st.uv === 'ushort' || st.weights === 'ushort' ? 1e-6 : 0;
    // (ubyte weights: small faces turn visibly, so only the centres are bounded)
    const ok = dm <= tol && (st.weights === 'ubyte' || dq <= 1e-6);
    console.log(`  ${st.name}: max |centre - original| ${dm.toExponential(2)} m, max |quaternion - original| ${dq.toExponential(2)}${ok ? '' : '  FAIL'}`);
    if (!ok) fail(`${v.name}, ${st.name}: Gaussians differ from the original`);
  }
}

// Bad input: one line naming the file.
const bad = async (label, mutate, expect) => {
  const g = readGlb(variants[0].file);
  const json = JSON.parse(JSON.stringify(g.json));
  mutate(json);
  const out = `${work}/bad.glb`;
  writeGlb(out, json, Buffer.from(g.bin));
  try {
    await loadAvatarNode(out);
    fail(`${label}: accepted`);
  } catch (e) {
    const ok = e.message.startsWith(out) && !e.message.includes('\n') && expect.test(e.message);
    console.log(`bad input, ${label}: ${e.message}${ok ? '' : '  FAIL'}`);
    if (!ok) fail(`${label}: unexpected error text`);
  }
};
await bad('version 9', (j) => { j.extensions.HAHA_gaussian_avatar.version = 9; }, /unsupported version 9/);
await bad('no extension', (j) => { delete j.extensions.HAHA_gaussian_avatar; }, /not a HAHA avatar/);
await bad('unknown faceOrder', (j) => { j.extensions.HAHA_gaussian_avatar.gaussians.faceOrder = 'sideways'; }, /faceOrder/);
await bad('bufferView outside the BIN chunk', (j) => { j.bufferViews[j.extensions.HAHA_gaussian_avatar.gaussians.bufferView ?? j.extensions.HAHA_gaussian_avatar.gaussians.tiers[0].bufferView].byteLength = 1e9; }, /outside the BIN chunk/);
await bad('CRC mismatch', (j) => { const g = j.extensions.HAHA_gaussian_avatar.gaussians; (g.tiers ? g.tiers[0] : g).crc32 ^= 1; }, /CRC-32 mismatch/);

console.log(failed ? 'FAIL' : 'PASS');
if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
process.exit(failed ? 1 : 0);
