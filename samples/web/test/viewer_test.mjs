#!/usr/bin/env node
// Browser test of the web viewer (CTest `web_viewer`, tests/web/web_viewer_test.sh):
//   1. a tiny avatar from the built `haha` (synth -> train tiny -> pack) and a motion
//      (`haha motion`), unless --avatar / --motion are given;
//   2. headless Debian Chromium (playwright-core, never a downloaded browser, WebGL2 through
//      SwiftShader) opens the viewer; the camera is the viewer's framing camera made
//      non-square with an off-centre principal point, written as cam.json;
//   3. `haha render --camera cam.json` renders the same motion frame;
//   4. PSNR of the viewer's pixels against haha render, with the Gaussian layer on and off:
//      passes when on >= --min-psnr (30 dB) and off < on; prints both and the frame time.
// Exit codes: 0 pass, 1 fail, 77 skip (no Chromium / node_modules).
import fs from 'node:fs';
import path from 'node:path';
import os from 'node:os';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const SKIP = 77;

const opts = { chromium: process.env.HAHA_CHROMIUM || '/usr/bin/chromium', 'min-psnr': '30', frame: '3', size: '128', keep: false };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i++) {
  const k = argv[i].replace(/^--/, '');
  if (k === 'keep') opts.keep = true;
  else opts[k] = argv[++i];
}
if (!fs.existsSync(opts.chromium)) {
  console.log(`SKIP web_viewer: no Chromium at ${opts.chromium} (apt-get install chromium, or set HAHA_CHROMIUM)`);
  process.exit(SKIP);
}
let chromium, PNG;
try {
  ({ chromium } = await import('playwright-core'));
  ({ PNG } = await import('pngjs'));
  if (!fs.existsSync(path.join(here, '..', 'node_modules', 'three'))) throw new Error('three missing');
} catch (e) {
  console.log(`SKIP web_viewer: samples/web/node_modules incomplete (${e.message}); run  npm ci --prefix samples/web`);
  process.exit(SKIP);
}
const { startServer, viewerUrl } = await import('../serve.mjs');

const work = opts.work ? path.resolve(opts.work) : fs.mkdtempSync(path.join(os.tmpdir(), 'haha-web-'));
fs.mkdirSync(work, { recursive: true });
const env = { ...process.env, OMP_WAIT_POLICY: process.env.OMP_WAIT_POLICY || 'passive' };
const run = (args) => {
  const t = Date.now();
  execFileSync(opts.haha, args, { stdio: ['ignore', 'ignore', 'inherit'], env });
  return (Date.now() - t) / 1000;
};

function readPng(file) {
  const p = PNG.sync.read(fs.readFileSync(file));
  const rgb = new Uint8Array(3 * p.width * p.height);
  for (let i = 0; i < p.width * p.height; i++) for (let c = 0; c < 3; c++) rgb[3 * i + c] = p.data[4 * i + c];
  return { width: p.width, height: p.height, rgb };
}
function writePng(file, { width, height, rgb }) {
  const p = new PNG({ width, height });
  for (let i = 0; i < width * height; i++) {
    for (let c = 0; c < 3; c++) p.data[4 * i + c] = rgb[3 * i + c];
    p.data[4 * i + 3] = 255;
  }
  fs.writeFileSync(file, PNG.sync.write(p));
}
// PSNR (data range 255) over all pixels, and over the pixels where either image differs
// from the background (the avatar's footprint).
function psnr(a, b, bg) {
  let se = 0, seFg = 0, nFg = 0, maxd = 0;
  for (let i = 0; i < a.width * a.height; i++) {
    let s = 0, fg = false;
    for (let c = 0; c < 3; c++) {
      const d = a.rgb[3 * i + c] - b.rgb[3 * i + c];
      s += d * d;
      maxd = Math.max(maxd, Math.abs(d));
      if (a.rgb[3 * i + c] !== bg[c] || b.rgb[3 * i + c] !== bg[c]) fg = true;
    }
    se += s;
    if (fg) { seFg += s; nFg++; }
  }
  const db = (sum, n) => (sum === 0 ? Infinity : 10 * Math.log10(255 * 255 / (sum / (3 * n))));
  return { all: db(se, a.width * a.height), fg: db(seFg, Math.max(1, nFg)), fgPixels: nFg, maxDiff: maxd };
}

const t0 = Date.now();
let avatar = opts.avatar && path.resolve(opts.avatar);
const packedHere = !avatar;  // then the file embeds pose correctives (the default pack)
let motion = opts.motion && path.resolve(opts.motion);
if (!opts.haha) { console.error('viewer_test: --haha PATH is required (the reference renderer)'); process.exit(1); }
if (!avatar) {
  const times = [];
  times.push(['synth', run(['synth', '--out', `${work}/data`, '--frames', '8', '--test-frames', '2', '--size', '64'])]);
  times.push(['train', run(['train', '--data', `${work}/data`, '--out', `${work}/run`, '--preset', 'tiny', 'resolution=64',
    's1.steps=50', 's1.densify.from=10', 's1.densify.until=40', 's1.densify.every=20', 's2.steps=30', 's2.texture_size=64',
    's3.steps=30', 's3.prune_every=20', 'log_every=1000'])]);
  // Pose correctives embedded (compact, the default): the viewer decodes them and reposes
  // like haha render. Two importance tiers: the viewer reads and joins both (haha pack --lod).
  times.push(['pack', run(['pack', `${work}/run`, '--out', `${work}/avatar.glb`, '--lod', '2'])]);
  avatar = `${work}/avatar.glb`;
  console.log(`avatar: ${avatar} (${times.map(([k, s]) => `${k} ${s.toFixed(1)} s`).join(', ')})`);
}
if (!motion) {
  run(['motion', '--kind', 'wave', '--frames', '8', '--out', `${work}/motion.npz`]);
  motion = `${work}/motion.npz`;
}
const frame = Number(opts.frame);

const files = { 'avatar.glb': avatar, 'motion.npz': motion, 'camera.json': `${work}/cam.json` };
const named = { avatar, motion };
const { server, base } = await startServer({ files, port: 0, quiet: true });
const browser = await chromium.launch({
  executablePath: opts.chromium,
  headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync',
    '--no-first-run', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
let failed = false;
try {
  const page = await browser.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  const open = async (extra) => {
    await page.goto(viewerUrl(base, named, { play: 0, loop: 0, ...extra }));
    try {
      return await page.evaluate(() => window.hahaViewer.ready);
    } catch (e) {
      throw new Error(`viewer failed to load: ${e.message}\n${errors.join('\n')}`);
    }
  };

  // The camera: the viewer's framing of the motion (render_run.cpp's framing camera), cropped
  // to a non-square image with an off-centre principal point, so that the pixel-centre and
  // axis conventions are all exercised.
  const info = await open({ frame });
  const size = Number(opts.size);
  const cam = await page.evaluate((n) => window.hahaViewer.framingCamera(n), size);
  cam.width = Math.round(size * 0.875);
  cam.height = Math.round(size * 1.0625);
  cam.K[0][2] -= 0.0645 * size;
  cam.K[1][2] += 0.0273 * size;
  fs.writeFileSync(`${work}/cam.json`, JSON.stringify(cam));
  console.log(`viewer: ${info.gaussians} Gaussians, ${info.vertices} vertices, ${info.frames} motion frames, ` +
              `loaded in ${info.loadMs.toFixed(0)} ms, ${info.floatBlend ? 'float32' : 'half-float'} accumulation` +
              `${info.poseCorrectives ? ', pose correctives' : ''}`);
  if (packedHere && !info.poseCorrectives) { console.log('FAIL: the default pack embeds pose correctives; the viewer has none'); failed = true; }

  // Reference: haha render of motion frame `frame` (frames 0 and `frame` with --every).
  fs.rmSync(`${work}/ref`, { recursive: true, force: true });
  run(['render', avatar, '--motion', motion, '--camera', `${work}/cam.json`, '--out', `${work}/ref`, '--background', '0,0,0',
    ...(frame > 0 ? ['--every', String(frame), '--max-frames', '2'] : ['--max-frames', '1'])]);
  const ref = readPng(`${work}/ref/frame_0000${frame > 0 ? 1 : 0}.png`);

  await open({ frame, camera: 'files/camera.json', bg: '0,0,0' });
  const grab = async (on, skin = 'exact') => {
    const { width, height, rgb } = await page.evaluate(([g, s]) => {
      window.hahaViewer.setGaussians(g);
      window.hahaViewer.setSkin(s);
      window.hahaViewer.render();
      return window.hahaViewer.pixels();
    }, [on, skin]);
    return { width, height, rgb: Uint8Array.from(Buffer.from(rgb, 'base64')) };
  };
  const on = await grab(true), off = await grab(false);
  // For information: the body skinned by three.js from the glTF skin (GPU, 4 influences,
  // joints from the node tree, GPU rasterization) instead of the exact path.
  const gltf = await grab(true, 'gltf');
  await page.evaluate(() => window.hahaViewer.setSkin('exact'));
  if (on.width !== ref.width || on.height !== ref.height) throw new Error(`size ${on.width}x${on.height}, reference ${ref.width}x${ref.height}`);
  writePng(`${work}/viewer_gaussians_on.png`, on);
  writePng(`${work}/viewer_gaussians_off.png`, off);
  // Side by side: haha render | viewer | viewer without Gaussians | 4 x |difference|.
  const W = ref.width, H = ref.height, strip = { width: 4 * W, height: H, rgb: new Uint8Array(12 * W * H) };
  for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) for (let c = 0; c < 3; c++) {
    const i = 3 * (y * W + x) + c, o = (k) => 3 * (y * 4 * W + k * W + x) + c;
    strip.rgb[o(0)] = ref.rgb[i]; strip.rgb[o(1)] = on.rgb[i]; strip.rgb[o(2)] = off.rgb[i];
    strip.rgb[o(3)] = Math.min(255, 4 * Math.abs(on.rgb[i] - ref.rgb[i]));
  }
  writePng(`${work}/compare.png`, strip);
  await page.locator('#view').screenshot({ path: `${work}/viewer_screenshot.png` });
  const pOn = psnr(on, ref, [0, 0, 0]), pOff = psnr(off, ref, [0, 0, 0]), pGltf = psnr(gltf, ref, [0, 0, 0]);
  await page.evaluate(() => window.hahaViewer.setGaussians(true));
  const bench = await page.evaluate(() => window.hahaViewer.benchmark(20));
  const fmt = (p) => `${p.all.toFixed(2)} dB (avatar pixels: ${p.fg.toFixed(2)} dB over ${p.fgPixels}; max |diff| ${p.maxDiff})`;
  console.log(`PSNR viewer vs haha render, Gaussians on : ${fmt(pOn)}`);
  console.log(`PSNR viewer vs haha render, Gaussians off: ${fmt(pOff)}`);
  console.log(`(information) body from three.js's glTF skin instead: ${fmt(pGltf)}`);
  console.log(`frame time (${ref.width}x${ref.height}, mean of 20, SwiftShader): ${bench.total.toFixed(2)} ms ` +
              `(repose ${bench.repose.toFixed(2)}, project+sort ${bench.project.toFixed(2)}, render+readback ${bench.gpu.toFixed(2)})`);
  if (errors.length) console.log(`browser errors:\n${errors.join('\n')}`);
  const minPsnr = Number(opts['min-psnr']);
  if (!(pOn.all >= minPsnr)) { console.log(`FAIL: PSNR with Gaussians ${pOn.all.toFixed(2)} < ${minPsnr} dB`); failed = true; }
  if (!(pOff.all < pOn.all)) { console.log('FAIL: turning the Gaussian layer off does not move the image away from haha render'); failed = true; }
  console.log(`images in ${work} (ref/frame_*.png, viewer_gaussians_on.png, viewer_gaussians_off.png); ${((Date.now() - t0) / 1000).toFixed(1)} s`);
} catch (e) {
  console.log(`FAIL: ${e.stack || e.message}`);
  failed = true;
} finally {
  await browser.close();
  server.close();
}
if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
process.exit(failed ? 1 : 0);
