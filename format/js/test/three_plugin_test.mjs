#!/usr/bin/env node
// Browser test of the three.js GLTFLoader plugin (CTest `js_three_plugin`,
// tests/web/format_js_test.sh): a plain three.js page (three_page.js) loads each pack variant
// of a tiny avatar with GLTFLoader + HahaGaussianAvatarPlugin, sets the skeleton's bones and
// renders with WebGLRenderer.render(scene, camera) in headless Debian Chromium.
//   1. a haha motion frame: PSNR against `haha render` (same camera, same pose) >= --min-psnr
//      (30 dB), for the GPU-skinned body (the default) and exactBody; Gaussians off is worse;
//   2. a raised left arm: PSNR against `haha render --params`, and the Gaussian centres
//      against the Node reader's exact reposing and against the faces three.js skins: no
//      Gaussian stays behind.
// Usage: three_plugin_test.mjs --haha PATH [--work DIR] [--size 128] [--frame 3]
// Exit codes: 0 pass, 1 fail, 77 skip (no Chromium / node_modules).
import fs from 'node:fs';
import {
  parseArgs, requireBrowser, runner, workDir, tinyRun, packVariants, readPng, writeStrip, psnr, fmtPsnr,
  startServer, launch, loadAvatarNode, readMotionFor, framingCameraJson, writeParamsNpz, checkCentres,
  decodeF64, decodeRgb, raisedArmPose,
} from './common.mjs';

const TEST = 'js_three_plugin';
const opts = parseArgs({ 'min-psnr': '30', frame: '3', size: '128' }, ['keep']);
const { chromium, PNG } = await requireBrowser(opts, TEST, ['three', 'fflate']);
if (!opts.haha) { console.error(`${TEST}: --haha PATH is required (the reference renderer)`); process.exit(1); }
const work = workDir(opts, 'haha-js-three-');
const run = runner(opts.haha);
const t0 = Date.now();
const runDir = tinyRun(run, work);
const variants = packVariants(run, opts.haha, runDir, work);
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

const files = Object.fromEntries(variants.map((v) => [`${v.name}.glb`, v.file]));
const { server, base } = await startServer(files);
const browser = await launch(chromium, opts);
let failed = false;
const fail = (m) => { console.log(`FAIL: ${m}`); failed = true; };
try {
  const page = await browser.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') errors.push(m.text()); });
  await page.goto(`${base}test/three_page.html`);
  await page.waitForFunction(() => window.hahaReady === true);
  for (const v of variants) {
    const ref = await loadAvatarNode(v.file);
    for (const exactBody of [false, true]) {
      const label = `${v.name}${exactBody ? ', exactBody' : ''}`;
      let info;
      try {
        info = await page.evaluate(([url, o]) => window.hahaTest.load(url, o), [`/files/${v.name}.glb`, { exactBody }]);
      } catch (e) {
        throw new Error(`plugin failed to load ${v.file}: ${e.message}\n${errors.join('\n')}`);
      }
      if (!exactBody) {
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
      writeStrip(PNG, `${work}/three_${v.name}${exactBody ? '_exact' : ''}_motion.png`, refs[v.name].motion, on);
      console.log(`  ${label}: motion frame ${frame} vs haha render: ${fmtPsnr(pOn)}; Gaussians off ${pOff.all.toFixed(2)} dB; ` +
                  `${on.visible} splats, render ${on.ms.toFixed(1)} ms`);
      if (!(pOn.all >= minPsnr)) fail(`${label}: PSNR ${pOn.all.toFixed(2)} < ${minPsnr} dB`);
      if (!(pOff.all < pOn.all)) fail(`${label}: the Gaussian layer does not bring the image closer to haha render`);
      // 2. raised arm: image, then centres
      const armImg = await shot(arm.pose, arm.transl);
      const pArm = psnr(armImg, refs[v.name].arm);
      writeStrip(PNG, `${work}/three_${v.name}${exactBody ? '_exact' : ''}_arm.png`, refs[v.name].arm, armImg);
      console.log(`  ${label}: raised arm vs haha render --params: ${fmtPsnr(pArm)}`);
      if (!(pArm.all >= minPsnr)) fail(`${label}: raised arm PSNR ${pArm.all.toFixed(2)} < ${minPsnr} dB`);
      if (exactBody) continue;
      await page.evaluate(() => window.hahaTest.setPose(new Array(165).fill(0), [0, 0, 0]));
      const rest = await page.evaluate(() => window.hahaTest.centres());
      await page.evaluate(([p, t]) => window.hahaTest.setPose(p, t), [Array.from(arm.pose), Array.from(arm.transl)]);
      const got = await page.evaluate(() => window.hahaTest.centres());
      ref.repose(arm.pose, arm.transl);
      if (!checkCentres(`  ${label}: raised arm, Gaussian centres`, decodeF64(got.means), ref.means, decodeF64(rest.means),
        decodeF64(got.centroids), decodeF64(rest.centroids), { exact: 1e-5, relative: 0.02 })) fail(`${label}: Gaussian centres`);
    }
  }
  if (errors.length) console.log(`browser messages:\n${errors.join('\n')}`);
  console.log(`images in ${work}; ${((Date.now() - t0) / 1000).toFixed(1)} s`);
} catch (e) {
  fail(e.stack || e.message);
} finally {
  await browser.close();
  server.close();
}
if (!failed && !opts.keep && !opts.work) fs.rmSync(work, { recursive: true, force: true });
process.exit(failed ? 1 : 0);
