#!/usr/bin/env node
// Browser test of Spark's SplatSkinning driven by the skinned KHR_gaussian_splatting primitive
// of a `haha pack --khr-gaussian-splatting` avatar (format/spec.md section 2; CTest
// `js_spark_skinning`, tests/web/format_js_test.sh spark). A plain three.js page
// (spark_page.js) loads the file with GLTFLoader + DRACOLoader, builds a Spark SplatMesh from
// the splat primitive's arrays, gives Spark's SplatSkinning (linear blend) the file's
// JOINTS_0/WEIGHTS_0 and drives its bones from the glTF skeleton posed with a raised left arm.
// Spark's skinned centres are computed here from exactly what its shader reads (the skin and
// bone texture data and the splats' float32 centres, with its GLSL's formula; the GPU does not
// hand them back), and checked:
//   (a) against linear blend skinning computed independently: Node, avatar.js's joint
//       transforms, the same 8-bit weights Spark holds (<= 1e-5 m); and, reported, three.js's
//       SkinnedMesh maths with the file's own 16-bit weights;
//   (b) against the exact face-frame reposing of format/js/avatar.js (splats matched to the
//       reader's Gaussians by rest centre): median / max distance, and "left behind": a splat
//       whose exact centre moves > 5 cm but whose skinned centre moves less than half as far
//       (at most --max-behind, default 1%, of those that move).
// Renders rest and raised arm with Spark in headless Chromium (SwiftShader WebGL2) and checks
// that the image changed on the left arm's side (spark_arm.png: rest | arm | 4 x |diff|).
// Usage: spark_skinning_test.mjs --haha PATH [--work DIR] [--run-from DIR] [--size 160] [--keep]
// Exit codes: 0 pass, 1 fail, 77 skip (no Chromium / node_modules).
import fs from 'node:fs';
import { execFileSync } from 'node:child_process';
import {
  parseArgs, requireBrowser, runner, workDir, tinyRun, runOnTestPage, loadAvatarNode, framingCameraJson,
  writePng, writeStrip, decodeRgb, SKIP,
} from './common.mjs';

const TEST = 'js_spark_skinning';
const opts = parseArgs({ size: '160', 'max-behind': '0.01' }, ['keep']);
const { chromium, PNG } = await requireBrowser(opts, TEST, ['three', 'fflate', '@sparkjsdev/spark']);
if (!opts.haha) { console.error(`${TEST}: --haha PATH is required`); process.exit(1); }
if (!execFileSync(opts.haha, ['pack', '--help'], { encoding: 'utf8' }).includes('--khr-gaussian-splatting')) {
  console.log(`SKIP ${TEST}: this haha has no pack --khr-gaussian-splatting`);
  process.exit(SKIP);
}
const work = workDir(opts, `haha-${TEST}-`);
const run = runner(opts.haha);
const t0 = Date.now();
const runDir = tinyRun(run, work, opts['run-from']);
const file = `${work}/avatar_splats.glb`;
run(['pack', runDir, '--out', file, '--khr-gaussian-splatting']);  // Draco body mesh, float32 splats

const bytes = (b64) => { const b = Buffer.from(b64, 'base64'); return b.buffer.slice(b.byteOffset, b.byteOffset + b.length); };
const dist = (a, i, b, k) => Math.hypot(a[3 * i] - b[3 * k], a[3 * i + 1] - b[3 * k + 1], a[3 * i + 2] - b[3 * k + 2]);
const median = (a) => { const s = Float64Array.from(a).sort(); return s.length ? s[s.length >> 1] : NaN; };
const mm = (m) => (m !== 0 && m < 1e-4 ? `${(1000 * m).toExponential(2)} mm` : `${(1000 * m).toFixed(4)} mm`);

// The pose: left shoulder (joint 16) +1.3 rad about z (lifts the +x arm), left elbow (18) bent.
const zero = { pose: new Float64Array(165), transl: new Float64Array(3) };
const arm = { pose: new Float64Array(165), transl: new Float64Array(3) };
arm.pose[3 * 16 + 2] = 1.3;
arm.pose[3 * 18 + 1] = -0.6;

// Exact reposing (the Node reader, tested equal to haha's C++ loader).
const ref = await loadAvatarNode(file);
ref.repose(zero.pose, zero.transl);
const exactRest = Float64Array.from(ref.means);
ref.repose(arm.pose, arm.transl);
const exactArm = Float64Array.from(ref.means);
const A = Float64Array.from(ref.skinning(arm.pose).A);  // 55 x 3 x 4, row-major
const cam = framingCameraJson(ref, [zero, arm], Number(opts.size));

// Spark's linear blend skinning (defineApplyCovSplatLBSkinning): weights (skin & 0xff) / 255,
// bones skin >> 8; basis = sum w mat3(bone texels 0..8), offset = sum w (texels 9..11);
// centre' = basis * centre + offset (column-major mat3, as GLSL).
function sparkSkinned(d) {
  const N = d.N, skin = new Uint16Array(bytes(d.skinData)), bone = new Float32Array(bytes(d.boneData));
  const c = new Float32Array(bytes(d.sparkCentres)), out = new Float64Array(3 * N);
  for (let i = 0; i < N; i++) {
    const x = c[4 * i], y = c[4 * i + 1], z = c[4 * i + 2];
    for (let k = 0; k < 4; k++) {
      const s = skin[4 * i + k], w = (s & 255) / 255, b = 16 * (s >> 8);
      if (w === 0) continue;
      for (let r = 0; r < 3; r++) out[3 * i + r] += w * (bone[b + r] * x + bone[b + 3 + r] * y + bone[b + 6 + r] * z + bone[b + 9 + r]);
    }
  }
  return { out, skin, centres: c };
}

// Independent linear blend skinning: avatar.js's joint transforms A_j, given weights.
function lbs(pos, joints, w, Aj) {
  const N = pos.length / 3, out = new Float64Array(3 * N);
  for (let i = 0; i < N; i++) {
    for (let k = 0; k < 4; k++) {
      const wk = w(i, k), a = 12 * joints[4 * i + k];
      if (wk === 0) continue;
      for (let r = 0; r < 3; r++) out[3 * i + r] += wk * (Aj[a + 4 * r] * pos[3 * i] + Aj[a + 4 * r + 1] * pos[3 * i + 1] + Aj[a + 4 * r + 2] * pos[3 * i + 2] + Aj[a + 4 * r + 3]);
    }
  }
  return out;
}

// Splat i -> reader Gaussian by rest centre (grid of 1 cm cells, nearest).
function matchByRest(pos, rest) {
  const N = pos.length / 3, M = rest.length / 3, cell = 0.01, grid = new Map();
  const key = (x, y, z) => `${x},${y},${z}`;
  for (let g = 0; g < M; g++) {
    const k = key(Math.floor(rest[3 * g] / cell), Math.floor(rest[3 * g + 1] / cell), Math.floor(rest[3 * g + 2] / cell));
    if (!grid.has(k)) grid.set(k, []);
    grid.get(k).push(g);
  }
  const match = new Int32Array(N).fill(-1);
  let worst = 0;
  for (let i = 0; i < N; i++) {
    const cx = Math.floor(pos[3 * i] / cell), cy = Math.floor(pos[3 * i + 1] / cell), cz = Math.floor(pos[3 * i + 2] / cell);
    let best = Infinity;
    for (let dx = -1; dx <= 1; dx++) for (let dy = -1; dy <= 1; dy++) for (let dz = -1; dz <= 1; dz++) {
      for (const g of grid.get(key(cx + dx, cy + dy, cz + dz)) || []) {
        const d = dist(pos, i, rest, g);
        if (d < best) { best = d; match[i] = g; }
      }
    }
    worst = Math.max(worst, best);
  }
  return { match, worst };
}

const failed = await runOnTestPage({ chromium, opts, files: { 'avatar.glb': file }, engine: 'spark', consoleTypes: ['error'] }, async ({ page, errors, fail }) => {
  let info;
  try {
    info = await page.evaluate((url) => window.hahaTest.load(url), '/files/avatar.glb');
  } catch (e) {
    throw new Error(`page failed to load ${file}: ${e.message}\n${errors.join('\n')}`);
  }
  console.log(`${info.N} splats: node ${info.node} (mesh ${info.mesh}, skin ${info.skin}, ${info.bones} joints), ` +
              `JOINTS_0 ${info.jointType}, WEIGHTS_0 ${info.weightType}${info.weightNormalized ? ' normalized' : ''}; reader: ${ref.N} Gaussians`);
  const shot = async (p) => {
    await page.evaluate(([q, t]) => window.hahaTest.setPose(q, t), [Array.from(p.pose), Array.from(p.transl)]);
    const d = await page.evaluate(() => window.hahaTest.data());
    const img = { width: cam.width, height: cam.height, rgb: decodeRgb(await page.evaluate((c) => window.hahaTest.render(c), cam)) };
    return { d, img };
  };
  const rest = await shot(zero), posed = await shot(arm);
  const N = info.N;
  const pos = new Float32Array(bytes(rest.d.position)), joints = new Uint8Array(bytes(rest.d.joints));
  const w16 = new Uint16Array(bytes(rest.d.weights));

  // 0. Spark holds the file's centres bit for bit; its 8-bit weights sum to 1.
  const sRest = sparkSkinned(rest.d), sArm = sparkSkinned(posed.d);
  let centreDiff = 0, badSum = 0;
  for (let i = 0; i < 3 * N; i++) centreDiff = Math.max(centreDiff, Math.abs(sArm.centres[4 * Math.floor(i / 3) + (i % 3)] - pos[i]));
  for (let i = 0; i < N; i++) {
    let s = 0;
    for (let k = 0; k < 4; k++) s += sArm.skin[4 * i + k] & 255;
    if (s !== 255) badSum++;
  }
  let restMax = 0;
  for (let i = 0; i < N; i++) restMax = Math.max(restMax, dist(sRest.out, i, pos, i));
  console.log(`Spark's centres vs the file's POSITION: max |diff| ${centreDiff}; 8-bit weight codes not summing to 255: ${badSum}; ` +
              `rest pose skinned vs POSITION: max ${mm(restMax)}`);
  // What the file's weights given to setSplatBones as they are would do: codes round(w * 255)
  // that do not sum to 255 scale the splat about the origin (reported, not used).
  let naiveBad = 0, naiveMove = 0;
  for (let i = 0; i < N; i++) {
    let s = 0;
    for (let k = 0; k < 4; k++) s += Math.round(w16[4 * i + k] / 65535 * 255);
    if (s !== 255) { naiveBad++; naiveMove = Math.max(naiveMove, Math.abs(s / 255 - 1) * Math.hypot(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2])); }
  }
  console.log(`  (WEIGHTS_0 rounded to 8 bits one by one: ${naiveBad} splats' codes would not sum to 255, moving them up to ${mm(naiveMove)} at rest)`);
  if (centreDiff !== 0) fail('Spark does not hold the file\'s float32 centres');
  if (badSum) fail(`${badSum} splats with 8-bit weights not summing to 1`);
  if (!(restMax <= 1e-5)) fail('rest pose does not keep the splats at POSITION');

  // (a) linear blend skinning, independently.
  const w8 = (i, k) => (sArm.skin[4 * i + k] & 255) / 255;
  const j8 = new Uint8Array(4 * N);
  for (let i = 0; i < 4 * N; i++) j8[i] = sArm.skin[i] >> 8;
  let jointsDiff = 0;
  for (let i = 0; i < 4 * N; i++) if (j8[i] !== joints[i] && w16[i] !== 0) jointsDiff++;
  const lbs8 = lbs(pos, j8, w8, A), lbs16 = lbs(pos, joints, (i, k) => w16[4 * i + k] / 65535, A);
  const three16 = new Float64Array(bytes(posed.d.threeLbs));
  const stats = (a, b) => { const d = new Float64Array(N); for (let i = 0; i < N; i++) d[i] = dist(a, i, b, i); return { med: median(d), max: d.reduce((m, x) => Math.max(m, x), 0) }; };
  const a8 = stats(sArm.out, lbs8), a16 = stats(sArm.out, three16), t16 = stats(three16, lbs16);
  console.log(`(a) Spark skinned centres vs linear blend skinning (avatar.js joint transforms, Spark's 8-bit weights): ` +
              `median ${mm(a8.med)}, max ${mm(a8.max)} (<= 0.01 mm); bones differing from JOINTS_0: ${jointsDiff}`);
  console.log(`    vs three.js SkinnedMesh.applyBoneTransform with the file's 16-bit WEIGHTS_0: median ${mm(a16.med)}, max ${mm(a16.max)} ` +
              `(8-bit weights); three.js vs avatar.js LBS, same 16-bit weights: max ${mm(t16.max)}`);
  if (!(a8.max <= 1e-5)) fail(`Spark's skinned centres differ from linear blend skinning by ${mm(a8.max)}`);
  if (jointsDiff) fail(`${jointsDiff} bone indices differ from JOINTS_0`);
  if (!(t16.max <= 1e-5)) fail('three.js and avatar.js linear blend skinning disagree');
  if (!(a16.max <= 5e-3)) fail(`8-bit weights move the splats by ${mm(a16.max)} (> 5 mm) from the file's skinning`);

  // (b) against the exact face-frame reposing.
  const { match, worst } = matchByRest(pos, exactRest);
  const dExact = new Float64Array(N);
  let moved = 0, behind = 0, unmatched = 0, worstBehind = Infinity;
  for (let i = 0; i < N; i++) {
    const g = match[i];
    if (g < 0) { unmatched++; continue; }
    dExact[i] = dist(sArm.out, i, exactArm, g);
    const exactMove = dist(exactArm, g, exactRest, g), skinMove = dist(sArm.out, i, pos, i);
    if (exactMove > 0.05) {
      moved++;
      worstBehind = Math.min(worstBehind, skinMove / exactMove);
      if (skinMove <= 0.5 * exactMove) behind++;
    }
  }
  const maxBehind = Number(opts['max-behind']);
  const exactMax = dExact.reduce((m, x) => Math.max(m, x), 0);
  console.log(`(b) vs the exact face-frame reposing (avatar.js; splats matched by rest centre, worst match ${mm(worst)}, ${unmatched} unmatched): ` +
              `median ${mm(median(dExact))}, max ${mm(exactMax)}; ${moved} splats move > 5 cm, ${behind} left behind ` +
              `(skinned move <= half the exact: ${(100 * behind / Math.max(1, moved)).toFixed(2)} %, allowed ${100 * maxBehind} %); ` +
              `smallest skinned/exact move ratio ${worstBehind.toFixed(3)}`);
  if (N !== ref.N || unmatched || !(worst <= 1e-3)) fail('splats do not match the reader\'s Gaussians by rest centre');
  if (!(moved > 0)) fail('no splat moved more than 5 cm: the pose did not reach the arm');
  if (!(behind <= maxBehind * moved)) fail(`${behind} of ${moved} splats left behind`);

  // Images: the splats followed the arm.
  writePng(PNG, `${work}/spark_rest.png`, rest.img);
  writePng(PNG, `${work}/spark_arm.png`, posed.img);
  writeStrip(PNG, `${work}/spark_rest_arm.png`, rest.img, posed.img);
  const W = cam.width, H = cam.height, fx = cam.K[0][0], cx = cam.K[0][2];
  const E = cam.world_to_camera, J = ref.restJoints;
  const col = (j) => { const X = J[3 * j], Z = J[3 * j + 2]; const xc = E[0][0] * X + E[0][3], zc = E[2][0] * X + E[2][2] * Z + E[2][3]; return fx * xc / zc + cx; };
  const spineCol = col(3);  // spine1: the avatar's middle in the image
  let lit = 0, changed = 0, leftSide = 0;
  for (let p = 0; p < W * H; p++) {
    let d = 0, on = false;
    for (let c = 0; c < 3; c++) { d = Math.max(d, Math.abs(rest.img.rgb[3 * p + c] - posed.img.rgb[3 * p + c])); if (rest.img.rgb[3 * p + c] > 8) on = true; }
    if (on) lit++;
    if (d > 32) { changed++; if ((p % W) > spineCol) leftSide++; }
  }
  console.log(`render ${W} x ${H}: ${lit} avatar pixels at rest; ${changed} pixels changed (> 32) with the raised arm, ` +
              `${leftSide} of them on the left arm's side (x > spine column ${spineCol.toFixed(1)}); ${work}/spark_rest_arm.png`);
  if (!(lit > 0.02 * W * H)) fail('Spark rendered (almost) nothing');
  if (!(changed > 0.005 * W * H && leftSide >= 0.9 * changed)) fail('the render did not follow the arm');
  if (errors.length) console.log(`browser messages:\n${errors.join('\n')}`);
  console.log(`${((Date.now() - t0) / 1000).toFixed(1)} s`);
});
if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
console.log(failed ? `${TEST}: FAIL` : `${TEST}: pass`);
process.exit(failed ? 1 : 0);
