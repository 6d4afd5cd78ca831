#!/usr/bin/env node
// glTF-Transform round trip of HAHA avatars (CTest `gltf_transform_roundtrip`,
// tests/interop/gltf_transform_test.sh), through the pipeline script
// format/js/gltf-transform/haha-gltf-transform.mjs with the HAHA_gaussian_avatar extension class:
//   1. a tiny avatar from the built `haha` (synth -> train tiny -> pack twice: the default Draco
//      pack with --khr-gaussian-splatting --lod 2, and --mesh-compression none), unless
//      --avatar / --avatar-none are given; a wave motion (`haha motion`, arm raised);
//   2. each avatar through glTF-Transform written plain and with Draco re-encoding (edgebreaker,
//      and once sequential; 16-bit positions), mostly with the body mesh and node moved to the end
//      of their lists (--reorder: every index the extension names changes);
//   3. `haha render` of every result against `haha render` of its input (motion frames 0 and 3,
//      the arm raised): passes at >= --min-psnr (60 dB) on every frame; the written JSON checked
//      (no body.draco, fresh checksums, _BODY_VERTEX kept, indices followed, KHR_gaussian_splatting
//      kept, extensionsRequired only with Draco);
//   also an avatar trained with a skirt (its garment the body mesh's second primitive) written
//   plain and Draco-re-encoded;
//   4. without the extension registered glTF-Transform drops it and haha rejects the result; a
//      version-2 file is refused on write with a one-line error.
// Exit codes: 0 pass, 1 fail, 77 skip (node_modules of format/js/gltf-transform missing).
import fs from 'node:fs';
import path from 'node:path';
import os from 'node:os';
import zlib from 'node:zlib';
import { execFileSync, spawnSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..', '..');
const pkg = path.join(root, 'format', 'js', 'gltf-transform');
const pipeline = path.join(pkg, 'haha-gltf-transform.mjs');
const SKIP = 77;

const opts = { 'min-psnr': '60', size: '128', keep: false };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i++) {
  const k = argv[i].replace(/^--/, '');
  if (k === 'keep') opts.keep = true;
  else opts[k] = argv[++i];
}
for (const m of ['@gltf-transform/core', '@gltf-transform/extensions', 'draco3dgltf', 'pngjs']) {
  if (!fs.existsSync(path.join(pkg, 'node_modules', m))) {
    console.log(`SKIP gltf_transform_roundtrip: ${m} is not installed; run  npm ci --prefix format/js/gltf-transform`);
    process.exit(SKIP);
  }
}
if (!opts.haha) { console.error('gltf_transform_test: --haha PATH is required'); process.exit(1); }
const { PNG } = createRequire(path.join(pkg, 'package.json'))('pngjs');
const { crc32 } = await import(pathToFileURL(path.join(pkg, 'haha-gaussian-avatar.mjs')).href);
// The same module instances the extension uses (its own node_modules).
const gt = await import(pathToFileURL(path.join(pkg, 'node_modules', '@gltf-transform', 'core', 'dist', 'index.js')).href);
const gtx = await import(pathToFileURL(path.join(pkg, 'node_modules', '@gltf-transform', 'extensions', 'dist', 'index.js')).href);
const draco3d = createRequire(path.join(pkg, 'package.json'))('draco3dgltf');

const work = opts.work ? path.resolve(opts.work) : fs.mkdtempSync(path.join(os.tmpdir(), 'haha-gltf-transform-'));
fs.mkdirSync(work, { recursive: true });
const env = { ...process.env, OMP_WAIT_POLICY: process.env.OMP_WAIT_POLICY || 'passive' };
const haha = (args) => {
  const t = Date.now();
  execFileSync(opts.haha, args, { stdio: ['ignore', 'ignore', 'inherit'], env });
  return (Date.now() - t) / 1000;
};
const transform = (args) => spawnSync(process.execPath, [pipeline, ...args], { encoding: 'utf8', env });

let failed = false;
const fail = (msg) => { console.log(`FAIL: ${msg}`); failed = true; };

function readPng(file) {
  const p = PNG.sync.read(fs.readFileSync(file));
  return { width: p.width, height: p.height, data: p.data };
}
// PSNR (data range 255) over the RGB channels of all pixels.
function psnr(a, b) {
  if (a.width !== b.width || a.height !== b.height) return -Infinity;
  let se = 0;
  for (let i = 0; i < a.width * a.height; i++) {
    for (let c = 0; c < 3; c++) { const d = a.data[4 * i + c] - b.data[4 * i + c]; se += d * d; }
  }
  return se === 0 ? Infinity : 10 * Math.log10((255 * 255) / (se / (3 * a.width * a.height)));
}
function readGlb(file) {
  const b = fs.readFileSync(file);
  if (b.readUInt32LE(0) !== 0x46546c67) throw new Error(`${file}: not a GLB`);
  const n = b.readUInt32LE(12);
  const json = JSON.parse(b.subarray(20, 20 + n).toString('utf8'));
  const bin = b.length > 20 + n ? b.subarray(28 + n, 28 + n + b.readUInt32LE(20 + n)) : Buffer.alloc(0);
  return { json, bin };
}
const viewBytes = ({ json, bin }, i) => {
  const v = json.bufferViews[i];
  return bin.subarray(v.byteOffset || 0, (v.byteOffset || 0) + v.byteLength);
};
// Renders frames 0 and 3 of the motion (the arm raised at 3) into DIR; returns the PNGs.
function render(avatar, dir) {
  fs.rmSync(dir, { recursive: true, force: true });
  haha(['render', avatar, '--motion', motion, '--out', dir, '--size', opts.size, '--every', '3', '--max-frames', '2',
    '--background', '0,0,0']);
  return fs.readdirSync(dir).filter((f) => f.endsWith('.png')).sort().map((f) => readPng(path.join(dir, f)));
}

// Checks on the written file's JSON and payloads.
function checkWritten(file, { draco, splats }) {
  const g = readGlb(file);
  const { json } = g;
  const ext = json.extensions && json.extensions.HAHA_gaussian_avatar;
  if (!ext) return fail(`${file}: HAHA_gaussian_avatar missing`);
  if (ext.body.draco) fail(`${file}: body.draco was kept`);
  const required = json.extensionsRequired || [];
  if (draco && !required.includes('KHR_draco_mesh_compression')) fail(`${file}: Draco mesh but KHR_draco_mesh_compression not required`);
  if (!draco && required.length) fail(`${file}: plain mesh but extensionsRequired ${JSON.stringify(required)}`);
  const prims = json.meshes[ext.body.mesh].primitives;  // the body's, then a garment's (version 4)
  if (ext.body.garment && ext.body.garment.draco) fail(`${file}: body.garment.draco was kept`);
  if (prims.length !== (ext.body.garment ? 2 : 1)) fail(`${file}: ${prims.length} body primitives`);
  for (const prim of prims) {
    if (!('_BODY_VERTEX' in prim.attributes)) fail(`${file}: _BODY_VERTEX lost`);
    else if (![5121, 5123, 5125].includes(json.accessors[prim.attributes._BODY_VERTEX].componentType)) fail(`${file}: _BODY_VERTEX is not unsigned integer`);
    const kd = prim.extensions && prim.extensions.KHR_draco_mesh_compression;
    if (draco && !(kd && '_BODY_VERTEX' in kd.attributes)) fail(`${file}: _BODY_VERTEX not in the Draco stream`);
  }
  if (json.nodes[ext.body.node].mesh !== ext.body.mesh || json.nodes[ext.body.node].skin !== ext.body.skin) {
    fail(`${file}: body.node ${ext.body.node} does not hold body.mesh / body.skin`);
  }
  // Every bufferView slot with its checksum; the texture image with texture.crc32.
  let checked = 0;
  const walk = (o) => {
    if (Array.isArray(o)) return o.forEach(walk);
    if (!o || typeof o !== 'object') return;
    for (const [k, v] of Object.entries(o)) {
      if (k === 'bufferView' || /BufferView$/.test(k)) {
        const ck = k === 'bufferView' ? 'crc32' : k.replace(/BufferView$/, 'Crc32');
        if (crc32(viewBytes(g, v)) !== o[ck]) fail(`${file}: ${k} ${v}: ${ck} does not match`);
        if (zlib.crc32 && zlib.crc32(viewBytes(g, v)) !== o[ck]) fail(`${file}: crc32 disagrees with zlib`);
        checked++;
      } else walk(v);
    }
  };
  walk(ext);
  const img = json.images[ext.texture.image];
  if (crc32(viewBytes(g, img.bufferView)) !== ext.texture.crc32) fail(`${file}: texture.crc32 does not match the image`);
  if (splats) {
    if (!ext.splats) fail(`${file}: splats dropped`);
    else {
      const sp = json.meshes[ext.splats.mesh].primitives[0];
      if (!(sp.extensions && sp.extensions.KHR_gaussian_splatting)) fail(`${file}: the splat primitive lost KHR_gaussian_splatting`);
      if (json.nodes[ext.splats.node].mesh !== ext.splats.mesh) fail(`${file}: splats.node does not hold splats.mesh`);
    }
  }
  return { checked, bodyMesh: ext.body.mesh, bodyNode: ext.body.node };
}

// The body mesh as haha binds Gaussians to it (spec section 2, faceOrder "canonical"): faces as
// body-vertex triples rotated to their smallest vertex and sorted, with the UVs of their corners;
// positions and skin weights per body vertex. Read with glTF-Transform (Draco decoded).
let gtIO = null;
async function bodyMesh(file) {
  if (!gtIO) {
    gtIO = new gt.NodeIO().registerExtensions(gtx.ALL_EXTENSIONS)
      .registerDependencies({ 'draco3d.decoder': await draco3d.createDecoderModule() });
    gtIO.setLogger(new gt.Logger(gt.Logger.Verbosity.ERROR));
  }
  const { json } = readGlb(file);
  const ext = json.extensions.HAHA_gaussian_avatar;
  const doc = await gtIO.read(file);
  const faces = [];
  const V = ext.body.vertexCount;
  const position = new Float64Array(3 * V);
  const weights = Array.from({ length: V }, () => new Map());
  // Every primitive (the body's, then a garment's): _BODY_VERTEX names vertices of the whole mesh.
  for (const prim of doc.getRoot().listMeshes()[ext.body.mesh].listPrimitives()) primitiveMesh(prim, faces, position, weights);
  faces.sort((p, q) => p.key[0] - q.key[0] || p.key[1] - q.key[1] || p.key[2] - q.key[2]);
  return { faces, position, weights };
}

function primitiveMesh(prim, faces, position, weights) {
  const bv = prim.getAttribute('_BODY_VERTEX').getArray();
  const pos = prim.getAttribute('POSITION').getArray();
  const uv = prim.getAttribute('TEXCOORD_0');
  const idx = prim.getIndices().getArray();
  for (let f = 0; f < idx.length / 3; f++) {
    const c = [idx[3 * f], idx[3 * f + 1], idx[3 * f + 2]];
    const b = c.map((i) => bv[i]);
    const r = b[0] <= b[1] && b[0] <= b[2] ? 0 : b[1] <= b[2] ? 1 : 2;
    const cc = [c[r], c[(r + 1) % 3], c[(r + 2) % 3]];
    faces.push({ key: cc.map((i) => bv[i]), uv: cc.map((i) => uv.getElement(i, [])) });
  }
  for (let i = 0; i < bv.length; i++) {
    for (let k = 0; k < 3; k++) position[3 * bv[i] + k] = pos[3 * i + k];
    if (weights[bv[i]].size) continue;
    for (let s = 0; prim.getAttribute(`JOINTS_${s}`); s++) {
      const j = prim.getAttribute(`JOINTS_${s}`).getElement(i, []), w = prim.getAttribute(`WEIGHTS_${s}`).getElement(i, []);
      for (let k = 0; k < 4; k++) if (w[k]) weights[bv[i]].set(j[k], (weights[bv[i]].get(j[k]) || 0) + w[k]);
    }
  }
}
// Largest differences of the written body mesh from the input's (Infinity: faces differ).
function compareMeshes(a, b) {
  let faces = a.faces.length === b.faces.length, uv = 0, pos = 0, weight = 0;
  for (let f = 0; faces && f < a.faces.length; f++) {
    const p = a.faces[f], q = b.faces[f];
    if (p.key[0] !== q.key[0] || p.key[1] !== q.key[1] || p.key[2] !== q.key[2]) faces = false;
    for (let k = 0; k < 3; k++) for (let t = 0; t < 2; t++) uv = Math.max(uv, Math.abs(p.uv[k][t] - q.uv[k][t]));
  }
  let lo = Infinity, hi = -Infinity;
  for (let i = 0; i < a.position.length; i++) {
    pos = Math.max(pos, Math.abs(a.position[i] - b.position[i]));
    lo = Math.min(lo, a.position[i]);
    hi = Math.max(hi, a.position[i]);
  }
  // Half a step of 16-bit quantization over the mesh's largest extent (Draco re-encoding of
  // float32 positions; 0 when the input was quantized the same way already).
  const posTolerance = ((hi - lo) / 65535 / 2) * 1.001;
  for (let v = 0; v < a.weights.length; v++) {
    for (const j of new Set([...a.weights[v].keys(), ...b.weights[v].keys()])) {
      weight = Math.max(weight, Math.abs((a.weights[v].get(j) || 0) - (b.weights[v].get(j) || 0)));
    }
  }
  return { faces, uv: faces ? uv : Infinity, pos, posTolerance, weight };
}

const t0 = Date.now();
let motion;
try {
  let avatar = opts.avatar && path.resolve(opts.avatar);
  let avatarNone = opts['avatar-none'] && path.resolve(opts['avatar-none']);
  if (!avatar || !avatarNone) {
    const times = [];
    const run = `${work}/run`;
    if (!fs.existsSync(`${run}/avatar.npz`)) {
      times.push(['synth', haha(['synth', '--out', `${work}/data`, '--frames', '8', '--test-frames', '2', '--size', '64'])]);
      times.push(['train', haha(['train', '--data', `${work}/data`, '--out', run, '--preset', 'tiny', 'resolution=64',
        's1.steps=50', 's1.densify.from=10', 's1.densify.until=40', 's1.densify.every=20', 's2.steps=30', 's2.texture_size=64',
        's3.steps=30', 's3.prune_every=20', 'log_every=1000'])]);
    }
    if (!avatar) {
      avatar = `${work}/avatar.glb`;
      times.push(['pack', haha(['pack', run, '--out', avatar, '--khr-gaussian-splatting', '--lod', '2'])]);
    }
    if (!avatarNone) {
      avatarNone = `${work}/avatar_none.glb`;
      times.push(['pack none', haha(['pack', run, '--out', avatarNone, '--mesh-compression', 'none'])]);
    }
    console.log(`avatars: ${avatar}, ${avatarNone} (${times.map(([k, s]) => `${k} ${s.toFixed(1)} s`).join(', ')})`);
  }
  // The avatar with a skirt (format version 4: the garment the body mesh's second primitive),
  // unless --avatar-garment is given.
  let avatarGarment = opts['avatar-garment'] && path.resolve(opts['avatar-garment']);
  if (!avatarGarment) {
    const skirt = `${work}/run_skirt`;
    if (!fs.existsSync(`${work}/data/dataset.json`)) haha(['synth', '--out', `${work}/data`, '--frames', '8', '--test-frames', '2', '--size', '64']);
    const s = haha(['train', '--data', `${work}/data`, '--out', skirt, '--preset', 'tiny', 'resolution=64', 's1.steps=50',
      's1.densify.from=10', 's1.densify.until=40', 's1.densify.every=20', 's2.steps=30', 's2.texture_size=64', 's3.steps=30',
      's3.prune_every=20', 'log_every=1000', 's0.garment.mode=skirt']);
    avatarGarment = `${work}/avatar_garment.glb`;
    haha(['pack', skirt, '--out', avatarGarment]);
    console.log(`avatar with a skirt: ${avatarGarment} (train ${s.toFixed(1)} s)`);
  }
  // What haha pack writes (spec section 2): _BODY_VERTEX unsigned short / int, plain or Draco.
  for (const f of [avatar, avatarNone]) {
    const { json } = readGlb(f);
    const p = json.meshes[json.extensions.HAHA_gaussian_avatar.body.mesh].primitives[0];
    const t = p.attributes._BODY_VERTEX === undefined ? 'missing' : json.accessors[p.attributes._BODY_VERTEX].componentType;
    if (t !== 5123 && t !== 5125) fail(`${path.basename(f)} (haha pack): _BODY_VERTEX componentType ${t}, the spec says unsigned short (5123) or int (5125)`);
  }
  motion = `${work}/motion.npz`;
  haha(['motion', '--kind', 'wave', '--frames', '8', '--out', motion]);

  const minPsnr = Number(opts['min-psnr']);
  const cases = [
    { name: 'draco_to_plain', input: avatar, args: ['--mesh-compression', 'none', '--reorder'], draco: false, splats: true },
    { name: 'draco_to_draco', input: avatar, args: ['--mesh-compression', 'draco', '--reorder'], draco: true, splats: true },
    { name: 'draco_to_draco_sequential', input: avatar, args: ['--mesh-compression', 'draco', '--draco-method', 'sequential'], draco: true, splats: true },
    { name: 'plain_to_plain', input: avatarNone, args: ['--mesh-compression', 'none'], draco: false, splats: false },
    { name: 'plain_to_draco', input: avatarNone, args: ['--mesh-compression', 'draco', '--reorder'], draco: true, splats: false },
    { name: 'plain_to_draco_sequential', input: avatarNone, args: ['--mesh-compression', 'draco', '--draco-method', 'sequential'], draco: true, splats: false },
    { name: 'garment_to_plain', input: avatarGarment, args: ['--mesh-compression', 'none', '--reorder'], draco: false, splats: false },
    { name: 'garment_to_draco', input: avatarGarment, args: ['--mesh-compression', 'draco', '--reorder'], draco: true, splats: false },
  ];
  const refs = new Map();
  for (const c of cases) {
    const out = `${work}/${c.name}.glb`;
    const r = transform([c.input, out, ...c.args]);
    if (r.status !== 0) { fail(`${c.name}: pipeline failed: ${(r.stderr || r.stdout).trim()}`); continue; }
    const info = checkWritten(out, c);
    // The mesh haha binds the Gaussians to, read back: same canonical faces, same corners' UVs,
    // positions and weights (Draco: within the quantization step of 16-bit positions).
    const m = compareMeshes(await bodyMesh(c.input), await bodyMesh(out));
    console.log(`${c.name}: body mesh read back: canonical faces ${m.faces ? 'equal' : 'DIFFER'}, max |diff| position ` +
                `${m.pos.toExponential(2)} m (allowed ${m.posTolerance.toExponential(2)}), UV ${m.uv.toExponential(2)}, weight ${m.weight.toExponential(2)}`);
    // A Draco re-encode of float UVs (plain packs) quantizes them at the script's 12 bits, as
    // haha pack's own Draco default does: half a step over the [0, 1] range.
    const uvTolerance = c.draco ? 0.5 / 4095 * 1.01 : 1e-6;
    if (!m.faces || m.pos > m.posTolerance || m.uv > uvTolerance || m.weight > 1e-6) fail(`${c.name}: the body mesh changed`);
    if (!refs.has(c.input)) refs.set(c.input, render(c.input, `${work}/ref_${path.basename(c.input, '.glb')}`));
    const ref = refs.get(c.input);
    let got;
    try {
      got = render(out, `${work}/out_${c.name}`);
    } catch (e) {
      fail(`${c.name}: haha render of the result failed`);
      continue;
    }
    if (got.length !== ref.length || !ref.length) { fail(`${c.name}: ${got.length} frames rendered, reference ${ref.length}`); continue; }
    const p = ref.map((im, i) => psnr(im, got[i]));
    const worst = Math.min(...p);
    console.log(`${c.name}: ${fs.statSync(c.input).size} -> ${fs.statSync(out).size} B, body mesh ${info ? info.bodyMesh : '?'} node ` +
                `${info ? info.bodyNode : '?'}, ${info ? info.checked : 0} payload checksums ok; PSNR vs haha render of the input ` +
                `(frames 0, 3): ${p.map((x) => (x === Infinity ? 'inf (identical)' : `${x.toFixed(2)} dB`)).join(', ')}`);
    if (!(worst >= minPsnr)) fail(`${c.name}: PSNR ${worst.toFixed(2)} < ${minPsnr} dB`);
  }

  // Without the extension registered: glTF-Transform drops it (and its payloads) with a
  // warning; haha then rejects the file.
  const plainOut = `${work}/without_extension.glb`;
  const r = transform([avatar, plainOut, '--without-haha']);
  if (r.status !== 0) fail(`--without-haha: pipeline failed: ${r.stderr.trim()}`);
  else {
    const { json } = readGlb(plainOut);
    const dropped = !(json.extensions && json.extensions.HAHA_gaussian_avatar) && !(json.extensionsUsed || []).includes('HAHA_gaussian_avatar');
    const rej = spawnSync(opts.haha, ['info', plainOut], { encoding: 'utf8', env });
    const msg = (rej.stderr || rej.stdout).trim().split('\n').pop();
    console.log(`without the extension registered: HAHA_gaussian_avatar ${dropped ? 'dropped' : 'KEPT'} ` +
                `(${fs.statSync(avatar).size} -> ${fs.statSync(plainOut).size} B; glTF-Transform warned: ` +
                `${/not registered|Missing optional extension/.test(r.stderr) ? 'yes' : 'no'}); haha info: exit ${rej.status}: ${msg}`);
    if (!dropped) fail('without the extension registered the extension survived (expected glTF-Transform to drop it)');
    if (rej.status === 0) fail('haha accepted a file without HAHA_gaussian_avatar');
  }

  // Version 2 files cannot be rewritten (their body-vertex map is private to haha's Draco stream).
  const v2 = path.join(root, 'tests', 'fuzz', 'corpus', 'avatar_glb', 'seed4_v2_compact_correctives.glb');
  if (fs.existsSync(v2)) {
    const r2 = transform([v2, `${work}/v2_out.glb`]);
    const line = r2.stderr.trim();
    console.log(`version-2 input: exit ${r2.status}: ${line}`);
    if (r2.status !== 1 || !/version-2/.test(line) || line.includes('\n')) fail('a version-2 file was not refused with one line');
  }
} catch (e) {
  fail(e.stack || e.message);
}
console.log(`${failed ? 'FAILED' : 'PASS'} in ${((Date.now() - t0) / 1000).toFixed(1)} s; files in ${work}`);
if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
process.exit(failed ? 1 : 0);
