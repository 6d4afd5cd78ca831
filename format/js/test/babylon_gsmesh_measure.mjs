#!/usr/bin/env node
// Measurement (not a CTest): Babylon.js's own GaussianSplattingMesh fed, through updateData(),
// the Gaussians the HAHA extension reposed for a motion frame, against `haha render`, next to
// the extension's own splat pass. Needs the files of a kept babylon_extension_test.mjs run:
//   node format/js/test/babylon_extension_test.mjs --haha build/cli/haha --work /tmp/w
//   node format/js/test/babylon_gsmesh_measure.mjs --work /tmp/w
// (uses avatar_plain.glb, motion.npz, cam.json and ref_plain/frame_00001.png of that run).
import fs from 'node:fs';
import {
  requireBrowser, parseArgs, readPng, psnr, fmtPsnr, startServer, launch, openTestPage, loadAvatarNode, readMotionFor, decodeRgb, writeStrip,
} from './common.mjs';

const opts = parseArgs({ frame: '3' });
const { chromium, PNG } = await requireBrowser(opts, 'babylon_gsmesh_measure', ['babylonjs', 'babylonjs-loaders', 'three']);
const work = opts.work;
if (!work || !fs.existsSync(`${work}/avatar_plain.glb`)) { console.error('babylon_gsmesh_measure: --work DIR of a kept babylon_extension_test.mjs run (with avatar_plain.glb) is required'); process.exit(1); }
const cam = JSON.parse(fs.readFileSync(`${work}/cam.json`));
const ref0 = await loadAvatarNode(`${work}/avatar_plain.glb`);
const motion = await readMotionFor(`${work}/motion.npz`, ref0);
const ref = readPng(PNG, `${work}/ref_plain/frame_00001.png`);
const { server, base } = await startServer({ 'plain.glb': `${work}/avatar_plain.glb` });
const browser = await launch(chromium, opts);
const { page } = await openTestPage(browser, base, 'babylon');
await page.evaluate(() => window.hahaTest.load('/files/plain.glb', {}));
const { pose, transl } = motion.frames[Number(opts.frame)];
await page.evaluate(([p, t]) => window.hahaTest.setPose(p, t), [Array.from(pose), Array.from(transl)]);
const mine = await page.evaluate((c) => window.hahaTest.render(c, true), cam);
console.log('own splat layer:', fmtPsnr(psnr({ width: cam.width, height: cam.height, rgb: decodeRgb(mine.rgb) }, ref)));
const t = await page.evaluate(async () => {
  const B = window.BABYLON, scene = B.Engine.Instances[0].scenes[B.Engine.Instances[0].scenes.length - 1];
  const layer = scene.metadata.hahaAvatars[0], a = layer.avatar;
  // .splat layout: centre f32 x 3, scale f32 x 3, RGBA u8 (A = opacity), rotation u8 x 4 (w, x, y, z: q * 128 + 128)
  const N = a.N, buf = new ArrayBuffer(32 * N), f = new Float32Array(buf), u = new Uint8Array(buf);
  const t0 = performance.now();
  for (let i = 0; i < N; i++) {
    for (let k = 0; k < 3; k++) { f[8 * i + k] = a.means[3 * i + k]; f[8 * i + 3 + k] = a.scales[3 * i + k]; }
    for (let k = 0; k < 3; k++) u[32 * i + 24 + k] = Math.round(255 * Math.min(1, Math.max(0, a.gColor[3 * i + k])));
    u[32 * i + 27] = Math.round(255 * a.gOpacity[i]);
    for (let k = 0; k < 4; k++) u[32 * i + 28 + k] = Math.max(0, Math.min(255, Math.round(a.quats[4 * i + k] * 128 + 128)));
  }
  layer.mesh.setEnabled(false);
  const gs = new B.GaussianSplattingMesh('gs', null, scene);
  gs.updateData(buf, undefined, { flipY: false });
  const t1 = performance.now();
  window._gs = gs;
  return { pack: t1 - t0 };
});
const shots = [];
for (let k = 0; k < 4; k++) {
  await new Promise((r) => setTimeout(r, 700));
  const r = await page.evaluate((c) => window.hahaTest.render(c, false), cam);
  const img = { width: cam.width, height: cam.height, rgb: decodeRgb(r.rgb) };
  console.log(`GaussianSplattingMesh (updateData of the plugin's posed Gaussians), render ${k} after ${((k + 1) * 0.7).toFixed(1)} s: ${fmtPsnr(psnr(img, ref))} (${r.ms.toFixed(0)} ms)`);
  shots.push(img);
}
writeStrip(PNG, `${work}/gsmesh.png`, ref, shots[shots.length - 1]);
console.log(`packing ${t.pack.toFixed(1)} ms; image: ${work}/gsmesh.png (haha render | GaussianSplattingMesh | 4 x |difference|)`);
await browser.close(); server.close();
