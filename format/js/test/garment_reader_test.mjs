#!/usr/bin/env node
// Node test of the engine-free reader (format/js/avatar.js; CTest `js_garment_reader`) on an
// avatar with a garment, packed three ways (the fuzz corpus' seeds, written by the C++
// packer): version 3 (the garment inside primitive 0), version 4 Draco and version 4 plain
// (the garment as the body mesh's primitive 1). Each reads back as one mesh, the garment's
// faces last in the Gaussians' face order, and reposes (body, garment and the Gaussians on
// it) like the others within the packs' quantization.
// Usage: garment_reader_test.mjs   Exit codes: 0 pass, 1 fail, 77 skip.
import fs from 'node:fs';
import path from 'node:path';
import { SKIP, jsRoot, loadAvatarNode, raisedArmPose } from './common.mjs';

if (!fs.existsSync(path.join(jsRoot, 'node_modules', 'three'))) {
  console.log('SKIP js_garment_reader: format/js/node_modules is missing: npm ci --prefix format/js');
  process.exit(SKIP);
}
const corpus = path.join(jsRoot, '..', '..', 'tests', 'fuzz', 'corpus', 'avatar_glb');
const packs = [['version 3', 'seed8_v3_garment.glb'], ['version 4, Draco', 'seed9_v4_garment.glb'], ['version 4, plain', 'seed10_v4_garment_plain.glb']];
let failed = false;
const fail = (m) => { console.log(`FAIL: ${m}`); failed = true; };
const maxDiff = (a, b) => { let d = 0; for (let i = 0; i < a.length; i++) d = Math.max(d, Math.abs(a[i] - b[i])); return d; };

const { pose, transl } = raisedArmPose();
const read = [];
for (const [name, file] of packs) {
  const a = await loadAvatarNode(path.join(corpus, file));
  const g = a.ext.body.garment;
  const primitives = a.glb.json.meshes[a.ext.body.mesh].primitives.length;
  // The garment's faces (on vertices firstVertex..V-1) are the last ones, as in the C++ loader.
  let misplaced = 0;
  for (let f = 0; f < a.F; f++) {
    const onGarment = a.faces[3 * f] >= g.firstVertex && a.faces[3 * f + 1] >= g.firstVertex && a.faces[3 * f + 2] >= g.firstVertex;
    if (onGarment !== (f >= g.firstFace)) misplaced++;
  }
  let carried = 0;
  for (let i = 0; i < a.N; i++) carried += a.gFace[i] >= g.firstFace;
  a.repose(pose, transl);
  console.log(`${name}: ${primitives} primitive(s), ${a.V} vertices, ${a.F} faces (garment from ${g.firstFace}), ` +
              `${a.N} Gaussians (${carried} on the garment), ${misplaced} faces out of place`);
  if (a.ext.version !== (name === 'version 3' ? 3 : 4)) fail(`${name}: version ${a.ext.version}`);
  if (primitives !== (name === 'version 3' ? 1 : 2)) fail(`${name}: ${primitives} primitives`);
  if (misplaced) fail(`${name}: ${misplaced} faces out of place`);
  if (carried !== g.gaussians) fail(`${name}: ${carried} Gaussians on the garment, the file says ${g.gaussians}`);
  read.push({ name, a, posed: Float64Array.from(a.posed), means: Float64Array.from(a.means) });
}
const [ref, ...others] = read;
for (const o of others) {
  if (o.a.V !== ref.a.V || o.a.F !== ref.a.F || o.a.N !== ref.a.N) { fail(`${o.name}: other counts than ${ref.name}`); continue; }
  const sameFaces = o.a.faces.every((v, i) => v === ref.a.faces[i]);
  const dv = maxDiff(o.posed, ref.posed), dm = maxDiff(o.means, ref.means);
  let dg = 0;  // the garment's posed vertices
  for (let i = 3 * ref.a.ext.body.garment.firstVertex; i < ref.posed.length; i++) dg = Math.max(dg, Math.abs(o.posed[i] - ref.posed[i]));
  // 16-bit Draco or float32 positions of the same rest mesh: vertices within 0.2 mm; the
  // Gaussians ride the small faces' frames, which turn with those steps: within 1 mm.
  const ok = sameFaces && dv < 2e-4 && dm < 1e-3;
  console.log(`  ${o.name} against ${ref.name}: same faces ${sameFaces}, max |vertex| ${dv.toExponential(2)} m ` +
              `(garment ${dg.toExponential(2)} m), max |Gaussian centre| ${dm.toExponential(2)} m${ok ? '' : '  FAIL'}`);
  if (!ok) fail(`${o.name}: reposes differently from ${ref.name}`);
}
console.log(failed ? 'FAIL' : 'PASS');
process.exit(failed ? 1 : 0);
