// Shared parts of the browser tests of the three.js plugin and the Babylon.js extension:
// a tiny avatar from the built `haha`, the reference renders, PNG/PSNR, a static server of
// format/js (node_modules included, never a CDN), headless Debian Chromium (playwright-core,
// never a downloaded browser), and the engine-free reader in Node for reference values.
import fs from 'node:fs';
import path from 'node:path';
import os from 'node:os';
import http from 'node:http';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

export const here = path.dirname(fileURLToPath(import.meta.url));
export const jsRoot = path.resolve(here, '..');  // format/js
export const SKIP = 77;

// --key value arguments (and bare --flags listed in flags).
export function parseArgs(defaults, flags = []) {
  const opts = { chromium: process.env.HAHA_CHROMIUM || '/usr/bin/chromium', ...defaults };
  const argv = process.argv.slice(2);
  for (let i = 0; i < argv.length; i++) {
    const k = argv[i].replace(/^--/, '');
    if (flags.includes(k)) opts[k] = true;
    else opts[k] = argv[++i];
  }
  return opts;
}

// Exits 77 with the reason when Chromium or the npm packages are missing; returns modules.
export async function requireBrowser(opts, testName, packages) {
  if (!fs.existsSync(opts.chromium)) {
    console.log(`SKIP ${testName}: no Chromium at ${opts.chromium} (apt-get install chromium, or set HAHA_CHROMIUM)`);
    process.exit(SKIP);
  }
  try {
    const { chromium } = await import('playwright-core');
    const { PNG } = await import('pngjs');
    for (const p of packages) if (!fs.existsSync(path.join(jsRoot, 'node_modules', p))) throw new Error(`${p} missing`);
    return { chromium, PNG };
  } catch (e) {
    console.log(`SKIP ${testName}: format/js/node_modules incomplete (${e.message}); run  npm ci --prefix format/js`);
    process.exit(SKIP);
  }
}

export function runner(haha) {
  const env = { ...process.env, OMP_WAIT_POLICY: process.env.OMP_WAIT_POLICY || 'passive' };
  return (args) => {
    const t = Date.now();
    execFileSync(haha, args, { stdio: ['ignore', 'ignore', 'inherit'], env });
    return (Date.now() - t) / 1000;
  };
}

export function workDir(opts, prefix) {
  const work = opts.work ? path.resolve(opts.work) : fs.mkdtempSync(path.join(os.tmpdir(), prefix));
  fs.mkdirSync(work, { recursive: true });
  return work;
}

// A tiny trained run (as samples/web/test/viewer_test.mjs makes it) in DIR/run: the one of
// --run-from DIR when given (CTest's js_avatar fixture trains it once for the three tests), or
// trained into the work folder unless already there.
// name 'run_skirt' with extra ['s0.garment.mode=skirt']: the same avatar trained with a
// skirt (format version 4: the garment is the body mesh's second primitive).
export function tinyRun(run, work, from, extra = [], name = 'run') {
  if (from && fs.existsSync(`${from}/${name}/avatar.npz`)) return `${from}/${name}`;
  const base = work;
  if (fs.existsSync(`${base}/${name}/avatar.npz`)) return `${base}/${name}`;
  if (!fs.existsSync(`${base}/data/dataset.json`)) run(['synth', '--out', `${base}/data`, '--frames', '8', '--test-frames', '2', '--size', '64']);
  run(['train', '--data', `${base}/data`, '--out', `${base}/${name}`, '--preset', 'tiny', 'resolution=64',
    's1.steps=50', 's1.densify.from=10', 's1.densify.until=40', 's1.densify.every=20', 's2.steps=30', 's2.texture_size=64',
    's3.steps=30', 's3.prune_every=20', 'log_every=1000', ...extra]);
  return `${base}/${name}`;
}

export const SKIRT = [['s0.garment.mode=skirt'], 'run_skirt'];

// The pack variants the tests load: the default (Draco mesh) and, when this haha writes
// format version 3, the Draco-free mesh (--mesh-compression none) with skinned splats.
export function packVariants(run, haha, runDir, work) {
  const help = execFileSync(haha, ['pack', '--help'], { encoding: 'utf8' });
  const variants = [{ name: 'draco', file: `${work}/avatar_draco.glb`, args: [] }];
  if (help.includes('--mesh-compression')) {
    variants.push({ name: 'plain', file: `${work}/avatar_plain.glb`, args: ['--mesh-compression', 'none', '--khr-gaussian-splatting'] });
  } else {
    console.log('note: this haha has no --mesh-compression (format version 2): the plain-mesh variant is not tested');
  }
  for (const v of variants) run(['pack', runDir, '--out', v.file, ...v.args]);
  return variants;
}

export function readPng(PNG, file) {
  const p = PNG.sync.read(fs.readFileSync(file));
  const rgb = new Uint8Array(3 * p.width * p.height);
  for (let i = 0; i < p.width * p.height; i++) for (let c = 0; c < 3; c++) rgb[3 * i + c] = p.data[4 * i + c];
  return { width: p.width, height: p.height, rgb };
}

export function writePng(PNG, file, { width, height, rgb }) {
  const p = new PNG({ width, height });
  for (let i = 0; i < width * height; i++) {
    for (let c = 0; c < 3; c++) p.data[4 * i + c] = rgb[3 * i + c];
    p.data[4 * i + 3] = 255;
  }
  fs.writeFileSync(file, PNG.sync.write(p));
}

// Side by side: reference | engine | 4 x |difference|.
export function writeStrip(PNG, file, ref, img) {
  const W = ref.width, H = ref.height, strip = { width: 3 * W, height: H, rgb: new Uint8Array(9 * W * H) };
  for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) for (let c = 0; c < 3; c++) {
    const i = 3 * (y * W + x) + c, o = (k) => 3 * (y * 3 * W + k * W + x) + c;
    strip.rgb[o(0)] = ref.rgb[i]; strip.rgb[o(1)] = img.rgb[i];
    strip.rgb[o(2)] = Math.min(255, 4 * Math.abs(img.rgb[i] - ref.rgb[i]));
  }
  writePng(PNG, file, strip);
}

// PSNR (data range 255) over all pixels, and over the avatar's footprint (either image off
// the black background).
export function psnr(a, b) {
  let se = 0, seFg = 0, nFg = 0, maxd = 0;
  for (let i = 0; i < a.width * a.height; i++) {
    let s = 0, fg = false;
    for (let c = 0; c < 3; c++) {
      const d = a.rgb[3 * i + c] - b.rgb[3 * i + c];
      s += d * d;
      maxd = Math.max(maxd, Math.abs(d));
      if (a.rgb[3 * i + c] !== 0 || b.rgb[3 * i + c] !== 0) fg = true;
    }
    se += s;
    if (fg) { seFg += s; nFg++; }
  }
  const db = (sum, n) => (sum === 0 ? Infinity : 10 * Math.log10(255 * 255 / (sum / (3 * n))));
  return { all: db(se, a.width * a.height), fg: db(seFg, Math.max(1, nFg)), fgPixels: nFg, maxDiff: maxd };
}
export const fmtPsnr = (p) => `${p.all.toFixed(2)} dB (avatar pixels: ${p.fg.toFixed(2)} dB over ${p.fgPixels}; max |diff| ${p.maxDiff})`;

const TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.mjs': 'text/javascript; charset=utf-8',
  '.json': 'application/json', '.wasm': 'application/wasm', '.glb': 'model/gltf-binary',
};

// Serves format/js/ at / and `files` ({ name: path }) at /files/<name>.
export function startServer(files) {
  const server = http.createServer((req, res) => {
    const p = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    let file;
    if (p.startsWith('/files/')) file = files[p.slice(7)];
    else {
      file = path.join(jsRoot, path.normalize(p).replace(/^(\.\.[/\\])+/, ''));
      if (!file.startsWith(jsRoot + path.sep)) file = undefined;
    }
    if (!file || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      res.writeHead(404, { 'content-type': 'text/plain' });
      res.end(`not found: ${p}\n`);
      return;
    }
    res.writeHead(200, { 'content-type': TYPES[path.extname(file)] || 'application/octet-stream', 'cache-control': 'no-store' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve, reject) => {
    server.on('error', reject);
    server.listen(0, '127.0.0.1', () => resolve({ server, base: `http://127.0.0.1:${server.address().port}/` }));
  });
}

// The test page of an engine (page.html?engine=three|babylon|spark), ready to drive through
// window.hahaTest; errors collects the page's errors and its console messages of consoleTypes.
export async function openTestPage(browser, base, engine, consoleTypes = ['error']) {
  const page = await browser.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (consoleTypes.includes(m.type())) errors.push(m.text()); });
  await page.goto(`${base}test/page.html?engine=${engine}`);
  await page.waitForFunction(() => window.hahaReady === true);
  return { page, errors };
}

// Serves format/js/ and `files` (startServer), opens the engine's test page in headless
// Chromium (openTestPage) and awaits body({ page, errors, fail }); fail(message) prints
// "FAIL: message", and so does an exception. Closes browser and server; returns whether
// anything failed.
export async function runOnTestPage({ chromium, opts, files, engine, consoleTypes }, body) {
  const { server, base } = await startServer(files);
  const browser = await launch(chromium, opts);
  let failed = false;
  const fail = (m) => { console.log(`FAIL: ${m}`); failed = true; };
  try {
    const { page, errors } = await openTestPage(browser, base, engine, consoleTypes);
    await body({ page, errors, fail });
  } catch (e) {
    fail(e.stack || e.message);
  } finally {
    await browser.close();
    server.close();
  }
  return failed;
}

export async function launch(chromium, opts) {
  return chromium.launch({
    executablePath: opts.chromium,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--no-first-run', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
  });
}

// Node-side reader (the reference for the engines' Gaussian centres): three's Draco decoder
// module, run synchronously.
let dracoModule = null;
export async function loadAvatarNode(file) {
  const { Avatar } = await import('../avatar.js');
  const { dracoDecode } = await import('../draco.js');
  if (!dracoModule) {
    const src = fs.readFileSync(path.join(jsRoot, 'node_modules/three/examples/jsm/libs/draco/draco_decoder.js'), 'utf8');
    const factory = new Function('module', 'exports', 'require', '__dirname', `${src}\nreturn DracoDecoderModule;`)(
      undefined, undefined, createRequire(import.meta.url), path.join(jsRoot, 'node_modules/three/examples/jsm/libs/draco'));
    dracoModule = await factory();
  }
  const b = fs.readFileSync(file);
  return Avatar.load(b.buffer.slice(b.byteOffset, b.byteOffset + b.length), dracoDecode(dracoModule), file);
}

// The motion (haha motion: AMASS-style) turned upright for this avatar, as haha render does.
export async function readMotionFor(file, avatar) {
  const { readMotion, motionToYUp } = await import('../npz.js');
  const b = fs.readFileSync(file);
  const m = readMotion(b.buffer.slice(b.byteOffset, b.byteOffset + b.length), file);
  return motionToYUp(m, avatar.restJoints.subarray(0, 3));
}

// render_run.cpp's framing camera over the given frames, as cam.json, cropped to a
// non-square image with an off-centre principal point (all conventions exercised).
export function framingCameraJson(avatar, frames, size) {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const { pose, transl } of frames) {
    avatar.reposeBody(pose, transl);
    for (let v = 0; v < avatar.V; v++) for (let k = 0; k < 3; k++) {
      lo[k] = Math.min(lo[k], avatar.posed[3 * v + k]);
      hi[k] = Math.max(hi[k], avatar.posed[3 * v + k]);
    }
  }
  const f = 1.5 * size;
  const centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
  const half = 0.5 * Math.max(hi[0] - lo[0], hi[1] - lo[1]) * 1.15;
  const dist = half * f / (0.5 * size) + 0.5 * (hi[2] - lo[2]);
  const eye = [centre[0], centre[1], centre[2] + dist];
  const cam = {
    width: Math.round(size * 0.875), height: Math.round(size * 1.0625),
    K: [[f, 0, 0.5 * size - 0.0645 * size], [0, f, 0.5 * size + 0.0273 * size], [0, 0, 1]],
    world_to_camera: [[1, 0, 0, -eye[0]], [0, -1, 0, eye[1]], [0, 0, -1, eye[2]], [0, 0, 0, 1]],
    near: 0.01, far: dist * 4 + 10,
  };
  return cam;
}

// A native SMPL-X parameter file (.npz of float64 .npy arrays) holding one pose, for
// `haha render --params`.
export async function writeParamsNpz(file, pose, transl) {
  const { zipSync } = await import('fflate');
  const npy = (values, shape) => {
    let header = `{'descr': '<f8', 'fortran_order': False, 'shape': (${shape.join(', ')}${shape.length === 1 ? ',' : ''}), }`;
    const pad = 64 - ((10 + header.length + 1) % 64);
    header += ' '.repeat(pad) + '\n';
    const out = new Uint8Array(10 + header.length + 8 * values.length);
    out.set([0x93, 0x4e, 0x55, 0x4d, 0x50, 0x59, 1, 0, header.length & 255, header.length >> 8]);
    for (let i = 0; i < header.length; i++) out[10 + i] = header.charCodeAt(i);
    const body = new Uint8Array(Float64Array.from(values).buffer);
    out.set(body, 10 + header.length);
    return out;
  };
  const parts = { global_orient: [0, 1], body_pose: [1, 21], jaw_pose: [22, 1], leye_pose: [23, 1], reye_pose: [24, 1],
    left_hand_pose: [25, 15], right_hand_pose: [40, 15] };
  const entries = {};
  for (const [k, [j0, n]] of Object.entries(parts)) entries[`${k}.npy`] = npy(pose.slice(3 * j0, 3 * (j0 + n)), [1, 3 * n]);
  entries['transl.npy'] = npy(transl, [1, 3]);
  fs.writeFileSync(file, zipSync(entries, { level: 0 }));
}

// "No Gaussian stays behind": the engine's Gaussian centres against (a) the Node reader's
// exact reposing of the same pose and (b) the centroids of their faces as the engine skins
// the body: a centre's distance to its face centroid may change only by the face's stretch
// (and the engine's 4-influence skin), never by the arm's motion.
export function checkCentres(label, got, ref, restGot, cen, restCen, tol) {
  const N = got.length / 3;
  let maxRef = 0, maxRel = 0, moved = 0, stayed = 0;
  for (let i = 0; i < N; i++) {
    const d = (a, b, o) => Math.hypot(a[o] - b[o], a[o + 1] - b[o + 1], a[o + 2] - b[o + 2]);
    maxRef = Math.max(maxRef, d(got, ref, 3 * i));
    const rel = Math.abs(d(got, cen, 3 * i) - d(restGot, restCen, 3 * i));
    maxRel = Math.max(maxRel, rel);
    const faceMove = d(cen, restCen, 3 * i), gMove = d(got, restGot, 3 * i);
    if (faceMove > 0.1) moved++;
    if (faceMove > 0.1 && gMove < 0.5 * faceMove) stayed++;
  }
  const ok = maxRef <= tol.exact && maxRel <= tol.relative && stayed === 0 && moved > 0;
  console.log(`${label}: ${N} Gaussians, ${moved} on faces that moved > 10 cm, ${stayed} left behind; ` +
              `max |centre - exact reference| ${(1000 * maxRef).toFixed(4)} mm (<= ${1000 * tol.exact}), ` +
              `max change of centre-to-face-centroid distance ${(1000 * maxRel).toFixed(2)} mm (<= ${1000 * tol.relative})` +
              `${ok ? '' : '  FAIL'}`);
  return ok;
}

export const decodeF64 = (b64) => { const b = Buffer.from(b64, 'base64'); return new Float64Array(b.buffer, b.byteOffset, b.length / 8); };
export const decodeRgb = (b64) => Uint8Array.from(Buffer.from(b64, 'base64'));

// The raised-arm test pose: left shoulder up (about +Z lifts the +X arm), elbow bent a little.
export function raisedArmPose() {
  const pose = new Float64Array(165);
  pose[3 * 16 + 2] = 1.3;   // left_shoulder
  pose[3 * 18 + 1] = -0.6;  // left_elbow
  pose[3 * 17 + 2] = -0.4;  // right_shoulder down a little
  return { pose, transl: new Float64Array(3) };
}

// The avatar packed with a glTF animation (a 40-frame wave at 30 fps, `haha pack
// --animation`, default keyframe reduction) and `haha render --animation 0`'s frame 30 of it,
// at the camera of the motion test (cam.json in work). HAHA_TEST_ANIMATION_MOTION=M.npz packs
// that motion instead (30 fps, at least 31 frames: a clip retargeted from another rig with
// `haha motion --retarget ... --fps 30`, say, which cannot be committed).
export const ANIMATION_FRAME = 30, ANIMATION_FPS = 30;
export function animationReference(run, PNG, runDir, work, packArgs) {
  const file = `${work}/avatar_anim.glb`, out = `${work}/ref_anim`;
  let motion = process.env.HAHA_TEST_ANIMATION_MOTION;
  if (motion) {
    console.log(`animation: ${motion} (HAHA_TEST_ANIMATION_MOTION) instead of the wave`);
  } else {
    motion = `${work}/anim_motion.npz`;
    run(['motion', '--kind', 'wave', '--frames', '40', '--fps', String(ANIMATION_FPS), '--out', motion]);
  }
  run(['pack', runDir, '--out', file, ...packArgs, '--animation', motion]);
  fs.rmSync(out, { recursive: true, force: true });
  run(['render', file, '--animation', '0', '--camera', `${work}/cam.json`, '--out', out, '--background', '0,0,0',
    '--every', String(ANIMATION_FRAME), '--max-frames', '2']);
  return { file, url: '/files/anim.glb', ref: readPng(PNG, `${out}/frame_00001.png`) };
}

// Loads the animated pack, plays its animation 0 through the engine's own animation system
// (the page's playAnimation: three's AnimationMixer, Babylon's AnimationGroup.goToFrame) to
// frame 30 and renders: PSNR against `haha render --animation 0` >= minPsnr.
async function checkAnimation(page, PNG, spec, anim, cam, mode, loadOptions, minPsnr) {
  const label = `animation${mode ? `, ${mode}` : ''}`;
  await page.evaluate(([url, o]) => window.hahaTest.load(url, o), [anim.url, loadOptions]);
  const t = ANIMATION_FRAME / ANIMATION_FPS;
  const shoot = async (seconds) => {
    const played = await page.evaluate((s) => window.hahaTest.playAnimation(0, s), seconds);
    const r = await page.evaluate((c) => window.hahaTest.render(c, true), cam);
    return { played, img: { width: cam.width, height: cam.height, rgb: decodeRgb(r.rgb) } };
  };
  // Control: the clip's first frame must be further from frame 30 than the played frame 30.
  const first = psnr((await shoot(0)).img, anim.ref);
  const { played, img } = await shoot(t);
  const p = psnr(img, anim.ref);
  writeStrip(PNG, `${path.dirname(anim.file)}/${spec.engine}${mode ? `_${mode}` : ''}_animation.png`, anim.ref, img);
  console.log(`  ${label}: '${played.name}' (${played.tracks} tracks, ${played.duration.toFixed(3)} s) at ${t} s ` +
              `(frame ${ANIMATION_FRAME}) vs haha render --animation 0: ${fmtPsnr(p)} (bar ${minPsnr} dB); ` +
              `its frame 0: ${first.all.toFixed(2)} dB`);
  return p.all >= minPsnr && first.all < p.all - 3;
}

// The browser test of one engine (spec: { test, engine, packages, modes: [[label, load
// options], ...], mixer }; the first mode is the engine's default, run on every pack variant
// and the only one whose Gaussian centres are checked; the others run on the last variant):
// returns the exit code.
//   1. a haha motion frame: PSNR against `haha render` (same camera, same pose) >= --min-psnr
//      (30 dB); the image without the Gaussians is further from it;
//   2. a raised left arm: PSNR against `haha render --params`, and the Gaussian centres
//      against the Node reader's exact reposing and against the faces the engine skins: no
//      Gaussian stays behind.
export async function engineTest(spec) {
  const TEST = spec.test;
  const opts = parseArgs({ 'min-psnr': '30', 'min-animation-psnr': '40', frame: '3', size: '128' }, ['keep']);
  const { chromium, PNG } = await requireBrowser(opts, TEST, spec.packages);
  if (!opts.haha) { console.error(`${TEST}: --haha PATH is required (the reference renderer)`); process.exit(1); }
  const work = workDir(opts, `haha-${TEST}-`);
  const run = runner(opts.haha);
  const t0 = Date.now();
  const runDir = tinyRun(run, work, opts['run-from']);
  const variants = packVariants(run, opts.haha, runDir, work);
  // The avatar with a skirt (Draco; every mode): the garment primitive skinned and reposed.
  const garment = { name: 'garment', file: `${work}/avatar_garment.glb`, args: [], allModes: true };
  run(['pack', tinyRun(run, work, opts['run-from'], ...SKIRT), '--out', garment.file]);
  variants.push(garment);
  if (!fs.existsSync(`${work}/motion.npz`)) run(['motion', '--kind', 'wave', '--frames', '8', '--out', `${work}/motion.npz`]);
  const frame = Number(opts.frame), size = Number(opts.size), minPsnr = Number(opts['min-psnr']);

  // Camera (framing the motion, as haha render's default does) and the reference renders.
  const ref0 = await loadAvatarNode(variants[0].file);
  const motion = await readMotionFor(`${work}/motion.npz`, ref0);
  const cam = framingCameraJson(ref0, motion.frames, size);
  fs.writeFileSync(`${work}/cam.json`, JSON.stringify(cam));
  const arm = raisedArmPose();
  await writeParamsNpz(`${work}/arm.npz`, arm.pose, arm.transl);
  const refs = {};
  for (const v of variants) {
    const out = `${work}/ref_${v.name}`;
    fs.rmSync(out, { recursive: true, force: true });
    run(['render', v.file, '--motion', `${work}/motion.npz`, '--camera', `${work}/cam.json`, '--out', out, '--background', '0,0,0',
      '--every', String(frame), '--max-frames', '2']);
    run(['render', v.file, '--params', `${work}/arm.npz`, '--camera', `${work}/cam.json`, '--out', `${out}/arm`, '--background', '0,0,0']);
    refs[v.name] = { motion: readPng(PNG, `${out}/frame_00001.png`), arm: readPng(PNG, `${out}/arm/frame_00000.png`) };
  }

  // 3. The file's own animation (haha pack --animation): a 40-frame wave at 30 fps, frame 30.
  const anim = animationReference(run, PNG, runDir, work, variants[0].args);
  const files = Object.fromEntries(variants.map((v) => [`${v.name}.glb`, v.file]));
  files['anim.glb'] = anim.file;
  const failed = await runOnTestPage({ chromium, opts, files, engine: spec.engine, consoleTypes: ['error', 'warning'] }, async ({ page, errors, fail }) => {
    for (const v of variants) {
      const ref = await loadAvatarNode(v.file);
      for (const [mode, loadOptions] of spec.modes) {
      if (mode && v !== variants[variants.length - 2] && !v.allModes) continue;  // the other modes on the plain variant and the garment only (time)
        const label = `${v.name}${mode ? `, ${mode}` : ''}`;
        let info;
        try {
          info = await page.evaluate(([url, o]) => window.hahaTest.load(url, o), [`/files/${v.name}.glb`, loadOptions]);
        } catch (e) {
          throw new Error(`plugin failed to load ${v.file}: ${e.message}\n${errors.join('\n')}`);
        }
        if (!mode) {
          console.log(`${v.name}: format version ${info.version}, ${info.draco ? 'Draco' : 'plain'} mesh, faceOrder ${info.faceOrder}, ` +
                      `${info.N} Gaussians, ${info.V} body vertices (${info.Vg} glTF), pose correctives ${info.poseCorrectives}, loaded in ${info.loadMs.toFixed(0)} ms`);
        }
        const shot = async (pose, transl, gaussians = true) => {
          await page.evaluate(([p, t]) => window.hahaTest.setPose(p, t), [Array.from(pose), Array.from(transl)]);
          const r = await page.evaluate(([c, g]) => window.hahaTest.render(c, g), [cam, gaussians]);
          return { width: cam.width, height: cam.height, rgb: decodeRgb(r.rgb), ms: r.ms, visible: r.visible };
        };
        // 1. motion frame
        const { pose, transl } = motion.frames[frame];
        const on = await shot(pose, transl), off = await shot(pose, transl, false);
        const pOn = psnr(on, refs[v.name].motion), pOff = psnr(off, refs[v.name].motion);
        writeStrip(PNG, `${work}/${spec.engine}_${v.name}${mode ? `_${mode}` : ''}_motion.png`, refs[v.name].motion, on);
        console.log(`  ${label}: motion frame ${frame} vs haha render: ${fmtPsnr(pOn)}; Gaussians off ${pOff.all.toFixed(2)} dB; ` +
                    `${on.visible} splats, render ${on.ms.toFixed(1)} ms`);
        if (!(pOn.all >= minPsnr)) fail(`${label}: PSNR ${pOn.all.toFixed(2)} < ${minPsnr} dB`);
        if (!(pOff.all < pOn.all)) fail(`${label}: the Gaussian layer does not bring the image closer to haha render`);
        // 2. raised arm: image, then centres
        const armImg = await shot(arm.pose, arm.transl);
        const pArm = psnr(armImg, refs[v.name].arm);
        writeStrip(PNG, `${work}/${spec.engine}_${v.name}${mode ? `_${mode}` : ''}_arm.png`, refs[v.name].arm, armImg);
        console.log(`  ${label}: raised arm vs haha render --params: ${fmtPsnr(pArm)}`);
        if (!(pArm.all >= minPsnr)) fail(`${label}: raised arm PSNR ${pArm.all.toFixed(2)} < ${minPsnr} dB`);
        if (mode) continue;
        await page.evaluate(() => window.hahaTest.setPose(new Array(165).fill(0), [0, 0, 0]));
        const rest = await page.evaluate(() => window.hahaTest.centres());
        await page.evaluate(([p, t]) => window.hahaTest.setPose(p, t), [Array.from(arm.pose), Array.from(arm.transl)]);
        const got = await page.evaluate(() => window.hahaTest.centres());
        ref.repose(arm.pose, arm.transl);
        if (!checkCentres(`  ${label}: raised arm, Gaussian centres`, decodeF64(got.means), ref.means, decodeF64(rest.means),
          decodeF64(got.centroids), decodeF64(rest.centroids), { exact: 1e-5, relative: 0.02 })) fail(`${label}: Gaussian centres`);
        if (spec.mixer) {  // the same pose driven by the engine's animation system
          await page.evaluate(() => window.hahaTest.setPose(new Array(165).fill(0), [0, 0, 0]));
          const tracks = await page.evaluate(([p, t]) => window.hahaTest.setPoseByMixer(p, t), [Array.from(arm.pose), Array.from(arm.transl)]);
          const byMixer = await page.evaluate(() => window.hahaTest.centres());
          if (!checkCentres(`  ${label}: raised arm played by ${spec.mixer} (${tracks} tracks), Gaussian centres`, decodeF64(byMixer.means), ref.means,
            decodeF64(rest.means), decodeF64(byMixer.centroids), decodeF64(rest.centroids), { exact: 1e-5, relative: 0.02 })) fail(`${label}: ${spec.mixer}`);
        }
      }
    }
    for (const [mode, loadOptions] of spec.modes) {
      if (!(await checkAnimation(page, PNG, spec, anim, cam, mode, loadOptions, Number(opts['min-animation-psnr'])))) fail(`${mode || 'default'}: animation frame`);
    }
    if (errors.length) console.log(`browser messages:\n${errors.join('\n')}`);
    console.log(`images in ${work}; ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  });
  if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
  return failed ? 1 : 0;
}
