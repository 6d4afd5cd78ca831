#!/usr/bin/env node
// Browser test of the Babylon.js glTF loader extension (CTest `js_babylon_extension`,
// tests/web/format_js_test.sh): a plain Babylon.js page (babylon_page.js, UMD build, WebGL2,
// Draco decoder served locally) imports each pack variant of a tiny avatar with the glTF loader
// and HAHA_gaussian_avatar registered, sets the joint nodes' rotations and renders the scene in
// headless Debian Chromium; checks in common.mjs engineTest: PSNR against `haha render` for a
// motion frame and a raised arm (>= 30 dB), right- and left-handed scenes, the GPU-skinned
// body (default) and exactBody; the raised arm's
// Gaussian centres against the exact reposing and the faces Babylon skins, the pose set on the
// joint nodes by hand and played by an AnimationGroup; and the file's own glTF animation (haha
// pack --animation), the AnimationGroup the glTF loader made, moved with goToFrame to the
// clip's frame 30, against `haha render --animation 0` (>= 40 dB over all pixels; its frame 0
// must score lower).
// Usage: babylon_extension_test.mjs --haha PATH [--work DIR] [--run-from DIR] [--size 128] [--frame 3] [--keep]
// Exit codes: 0 pass, 1 fail, 77 skip (no Chromium / node_modules).
import { engineTest } from './common.mjs';

process.exit(await engineTest({
  test: 'js_babylon_extension', engine: 'babylon',
  packages: ['babylonjs', 'babylonjs-loaders', 'three', 'fflate'], modes: [['', {}], ['leftHanded', { leftHanded: true }], ['exactBody', { exactBody: true }]], mixer: 'an AnimationGroup',
}));
