#!/usr/bin/env node
// One measurement (docs/results.md, "Animations in the file"), not a CTest: an animated pack
// played by three.js's AnimationMixer (or Babylon's AnimationGroup) to frame F of its
// animation 0, against `haha render --animation 0` of that frame at a camera framing the motion.
// Usage: measure_animation_frame.mjs --haha PATH --avatar A.glb --motion M.npz --work DIR
//        [--engine three|babylon] [--frame 30] [--fps RATE] [--size 256] [--exactBody]
import fs from 'node:fs';
import {
  parseArgs, requireBrowser, runner, loadAvatarNode, readMotionFor, framingCameraJson, readPng, psnr, fmtPsnr,
  decodeRgb, runOnTestPage, writeStrip,
} from './common.mjs';

const opts = parseArgs({ engine: 'three', frame: '30', size: '256' }, ['exactBody']);
const { chromium, PNG } = await requireBrowser(opts, 'measure_animation_frame', ['three', 'fflate']);
const run = runner(opts.haha);
fs.mkdirSync(opts.work, { recursive: true });
const ref = await loadAvatarNode(opts.avatar);
const motion = await readMotionFor(opts.motion, ref);
const fps = Number(opts.fps || motion.fps), frame = Number(opts.frame);
const cam = framingCameraJson(ref, motion.frames, Number(opts.size));
fs.writeFileSync(`${opts.work}/cam.json`, JSON.stringify(cam));
fs.rmSync(`${opts.work}/ref`, { recursive: true, force: true });
run(['render', opts.avatar, '--animation', '0', '--camera', `${opts.work}/cam.json`, '--out', `${opts.work}/ref`,
  '--background', '0,0,0', '--every', String(frame), '--max-frames', '2']);
const want = readPng(PNG, `${opts.work}/ref/frame_00001.png`);
const failed = await runOnTestPage({ chromium, opts, files: { 'a.glb': opts.avatar }, engine: opts.engine }, async ({ page }) => {
  await page.evaluate((o) => window.hahaTest.load('/files/a.glb', o), { exactBody: !!opts.exactBody });
  const played = await page.evaluate((s) => window.hahaTest.playAnimation(0, s), frame / fps);
  const r = await page.evaluate((c) => window.hahaTest.render(c, true), cam);
  const img = { width: cam.width, height: cam.height, rgb: decodeRgb(r.rgb) };
  writeStrip(PNG, `${opts.work}/${opts.engine}_frame${frame}.png`, want, img);
  console.log(`${opts.engine}${opts.exactBody ? ', exactBody' : ''}: '${played.name}' (${played.tracks} tracks) at ${(frame / fps).toFixed(4)} s (frame ${frame} at ` +
              `${fps} fps) vs haha render --animation 0: ${fmtPsnr(psnr(img, want))}`);
});
process.exit(failed ? 1 : 0);
