#!/usr/bin/env node
// Browser test of the three.js GLTFLoader plugin (CTest `js_three_plugin`,
// tests/web/format_js_test.sh): a plain three.js page (three_page.js) loads each pack variant
// of a tiny avatar with GLTFLoader + HahaGaussianAvatarPlugin, sets the skeleton's bones and
// renders with WebGLRenderer.render(scene, camera) in headless Debian Chromium; checks in
// common.mjs engineTest: PSNR against `haha render` for a motion frame and a raised arm
// (>= 30 dB), the body GPU-skinned by three.js (default) and exactBody; the Gaussian centres
// of the raised arm against the exact reposing and the skinned faces, the pose set on the
// bones by hand and played by an AnimationMixer; and the file's own glTF animation (haha pack
// --animation) played by an AnimationMixer over gltf.animations[0] to frame 30 against `haha
// render --animation 0` (>= 40 dB over all pixels; its frame 0 must score lower).
// Usage: three_plugin_test.mjs --haha PATH [--work DIR] [--run-from DIR] [--size 128] [--frame 3] [--keep]
// Exit codes: 0 pass, 1 fail, 77 skip (no Chromium / node_modules).
import { engineTest } from './common.mjs';

process.exit(await engineTest({
  test: 'js_three_plugin', engine: 'three', packages: ['three', 'fflate'],
  modes: [['', {}], ['exactBody', { exactBody: true }]], mixer: 'an AnimationMixer',
}));
