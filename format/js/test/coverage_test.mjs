#!/usr/bin/env node
// The mesh coverage (COLOR_0 alpha with alphaMode MASK, format/spec.md section 2) in the
// reader and the engines (CTest `js_coverage`, no training: the fuzz corpus' seeds written by
// the C++ packer, a garment avatar with and without a coverage, vertex v at 0, 1, 0.3 for
// v % 3 = 0, 1, 2).
//   - reader (Node): meshCoverage per body vertex from Draco, plain and lossless packs (exact
//     in lossless, within half an 8-bit step otherwise), null without one; a file whose
//     material does not cut (alphaMode removed) is refused with one line naming it; the coverage
//     survives glTF-Transform (format/js/gltf-transform) writing the Draco seed plain and
//     Draco-re-encoded (skipped without that package's node_modules);
//   - three.js plugin and Babylon.js extension (headless Chromium, GPU-skinned and exactBody):
//     the mesh drawn alone is cut (fewer pixels, none outside the uncut mesh's), and the
//     Gaussians show through the cut (the depth buffer honours it: more of them are seen over
//     the cut-away part than over the same pixels of the uncut mesh).
// Usage: coverage_test.mjs [--reader-only]   Exit codes: 0 pass, 1 fail, 77 skip.
import fs from 'node:fs';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import {
  SKIP, jsRoot, parseArgs, requireBrowser, runOnTestPage, loadAvatarNode, framingCameraJson, decodeRgb,
} from './common.mjs';

const opts = parseArgs({}, ['reader-only']);
if (!fs.existsSync(path.join(jsRoot, 'node_modules', 'three'))) {
  console.log('SKIP js_coverage: format/js/node_modules is missing: npm ci --prefix format/js');
  process.exit(SKIP);
}
const corpus = path.join(jsRoot, '..', '..', 'tests', 'fuzz', 'corpus', 'avatar_glb');
const file = (name) => path.join(corpus, name);
let failed = false;
const fail = (m) => { console.log(`FAIL: ${m}`); failed = true; };
const want = (v) => [0, 1, Math.fround(0.3)][v % 3];

// --- the reader ---
for (const [name, seed, exact] of [['Draco', 'seed11_v4_coverage.glb', false], ['plain', 'seed12_v4_coverage_plain.glb', false],
  ['lossless', 'seed13_v4_coverage_lossless.glb', true]]) {
  const a = await loadAvatarNode(file(seed));
  const c = a.meshCoverage;
  if (!c || c.length !== a.V) { fail(`${name}: meshCoverage ${c && c.length}, expected ${a.V} values`); continue; }
  let worst = 0, sides = 0;
  for (let v = 0; v < a.V; v++) {
    worst = Math.max(worst, Math.abs(c[v] - want(v)));
    sides += (c[v] >= 0.5) !== (want(v) >= 0.5);
  }
  const ok = (exact ? worst === 0 : worst <= 0.5 / 255 + 1e-7) && sides === 0;
  console.log(`reader, ${name}: ${a.V} values, max |error| ${worst.toExponential(2)}, ${sides} on the wrong side of the cut${ok ? '' : '  FAIL'}`);
  if (!ok) fail(`${name}: coverage read back wrong`);
}
for (const seed of ['seed9_v4_garment.glb', 'seed10_v4_garment_plain.glb']) {
  const a = await loadAvatarNode(file(seed));
  if (a.meshCoverage !== null) fail(`${seed}: a file without a coverage gives meshCoverage ${a.meshCoverage}`);
}
// A coverage whose material does not cut: refused, the file named.
{
  const b = fs.readFileSync(file('seed12_v4_coverage_plain.glb'));
  const jsonLength = b.readUInt32LE(12);
  const json = JSON.parse(b.subarray(20, 20 + jsonLength).toString('utf8'));
  delete json.materials[0].alphaMode;
  let text = JSON.stringify(json);
  while (text.length % 4) text += ' ';
  const rest = b.subarray(20 + jsonLength);
  const out = Buffer.alloc(20 + text.length + rest.length);
  b.copy(out, 0, 0, 12);
  out.writeUInt32LE(out.length, 8);
  out.writeUInt32LE(text.length, 12);
  out.writeUInt32LE(0x4e4f534a, 16);
  out.write(text, 20, 'utf8');
  rest.copy(out, 20 + text.length);
  const bad = path.join(fs.mkdtempSync(path.join(fs.realpathSync('/tmp'), 'haha-coverage-')), 'no_mask.glb');
  fs.writeFileSync(bad, out);
  try {
    await loadAvatarNode(bad);
    fail('a COLOR_0 without alphaMode MASK loaded');
  } catch (e) {
    const ok = e.message.startsWith(`${bad}: `) && e.message.includes('without its material\'s alphaMode MASK') && !e.message.includes('\n');
    console.log(`reader, no MASK: "${e.message}"${ok ? '' : '  FAIL'}`);
    if (!ok) fail('the error should be one line naming the file and the missing MASK');
  }
  fs.rmSync(path.dirname(bad), { recursive: true });
}
// glTF-Transform keeps COLOR_0 and the material's alpha mode through a rewrite.
const transform = path.join(jsRoot, 'gltf-transform');
if (fs.existsSync(path.join(transform, 'node_modules', '@gltf-transform'))) {
  const dir = fs.mkdtempSync(path.join(fs.realpathSync('/tmp'), 'haha-coverage-'));
  for (const m of ['none', 'draco']) {
    const out = path.join(dir, `${m}.glb`);
    const r = spawnSync(process.execPath, [path.join(transform, 'haha-gltf-transform.mjs'), file('seed11_v4_coverage.glb'), out,
      '--mesh-compression', m, '--reorder'], { encoding: 'utf8' });
    if (r.status !== 0) { fail(`glTF-Transform --mesh-compression ${m}: ${r.stderr.trim()}`); continue; }
    const c = (await loadAvatarNode(out)).meshCoverage;
    let worst = c ? 0 : Infinity;
    for (let v = 0; c && v < c.length; v++) worst = Math.max(worst, Math.abs(c[v] - want(v)));
    const ok = worst <= 0.5 / 255 + 1e-7;
    console.log(`reader, after glTF-Transform (${m}): max |error| ${worst.toExponential(2)}${ok ? '' : '  FAIL'}`);
    if (!ok) fail(`glTF-Transform (${m}) lost the coverage`);
  }
  fs.rmSync(dir, { recursive: true });
} else {
  console.log('(glTF-Transform step skipped: format/js/gltf-transform/node_modules is missing)');
}
if (opts['reader-only']) {
  console.log(failed ? 'FAIL' : 'PASS');
  process.exit(failed ? 1 : 0);
}

// --- the engines ---
const { chromium } = await requireBrowser(opts, 'js_coverage', ['three', 'babylonjs', 'babylonjs-loaders']);
const ref = await loadAvatarNode(file('seed9_v4_garment.glb'));
const rest = { pose: new Float64Array(165), transl: [0, 0, 0] };
const cam = framingCameraJson(ref, [rest], 160);
const files = { cut: file('seed11_v4_coverage.glb'), whole: file('seed9_v4_garment.glb'),
  cut_plain: file('seed12_v4_coverage_plain.glb'), whole_plain: file('seed10_v4_garment_plain.glb') };
const lit = (rgb, i) => rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2] > 0;
const differ = (a, b, i) => a[3 * i] !== b[3 * i] || a[3 * i + 1] !== b[3 * i + 1] || a[3 * i + 2] !== b[3 * i + 2];

const far = (a, b, i) => Math.abs(a[3 * i] - b[3 * i]) + Math.abs(a[3 * i + 1] - b[3 * i + 1]) + Math.abs(a[3 * i + 2] - b[3 * i + 2]) > 30;

// One file in one mode: the image with (full) and, GPU-skinned only, without the Gaussians
// (the exact body is a child of the Gaussian layer: hidden with it).
async function shoot(page, url, options) {
  await page.evaluate(([u, o]) => window.hahaTest.load(u, o), [url, options]);
  await page.evaluate(([p, t]) => window.hahaTest.setPose(p, t), [Array.from(rest.pose), rest.transl]);
  const full = decodeRgb((await page.evaluate((c) => window.hahaTest.render(c, true), cam)).rgb);
  const mesh = options.exactBody ? null : decodeRgb((await page.evaluate((c) => window.hahaTest.render(c, false), cam)).rgb);
  return { full, mesh };
}

for (const engine of ['three', 'babylon']) {
  failed = await runOnTestPage({ chromium, opts, files, engine }, async ({ page, errors, fail: pageFail }) => {
    for (const storage of ['', '_plain']) {
      const label = `${engine}, ${storage ? 'plain' : 'Draco'}`;
      const cut = await shoot(page, `/files/cut${storage}`, {}), whole = await shoot(page, `/files/whole${storage}`, {});
      const n = cam.width * cam.height;
      let cutLit = 0, wholeLit = 0, outside = 0, throughCut = 0, throughWhole = 0;
      const region = [];  // pixels the cut took away from the mesh
      for (let i = 0; i < n; i++) {
        const c = lit(cut.mesh, i), w = lit(whole.mesh, i);
        cutLit += c;
        wholeLit += w;
        outside += c && !w;
        if (w && !c) {  // the Gaussians over these pixels, with and without the cut
          region.push(i);
          throughCut += differ(cut.full, cut.mesh, i);
          throughWhole += differ(whole.full, whole.mesh, i);
        }
      }
      let ok = cutLit < 0.9 * wholeLit && outside <= 0.01 * cutLit && throughCut > throughWhole;
      console.log(`${label}, GPU-skinned: mesh ${cutLit} px cut / ${wholeLit} px whole (${outside} outside), Gaussians over ` +
                  `the ${region.length} cut-away px: ${throughCut} with the cut, ${throughWhole} without${ok ? '' : '  FAIL'}`);
      if (!ok) pageFail(`${label}: the mesh is not cut where the coverage is low, or the Gaussians do not show through`);
      // exactBody: over the cut-away pixels its images look like the GPU-skinned cut one, not
      // like the uncut mesh.
      const exactCut = await shoot(page, `/files/cut${storage}`, { exactBody: true });
      const exactWhole = await shoot(page, `/files/whole${storage}`, { exactBody: true });
      const offCut = region.filter((i) => far(exactCut.full, cut.full, i)).length;
      const offWhole = region.filter((i) => far(exactWhole.full, cut.full, i)).length;
      ok = offCut <= 0.1 * region.length && offWhole >= 0.3 * region.length;
      console.log(`${label}, exactBody: over the cut-away px, ${offCut} differ from the GPU-skinned cut image ` +
                  `(the uncut exact body: ${offWhole})${ok ? '' : '  FAIL'}`);
      if (!ok) pageFail(`${label}: exactBody does not cut the mesh like the GPU-skinned body`);
    }
    for (const e of errors) pageFail(`${engine} page: ${e}`);
  }) || failed;
}
console.log(failed ? 'FAIL' : 'PASS');
process.exit(failed ? 1 : 0);
