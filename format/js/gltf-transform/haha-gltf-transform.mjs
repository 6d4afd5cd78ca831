#!/usr/bin/env node
// A glTF-Transform pipeline over a HAHA avatar, with HAHA_gaussian_avatar registered:
//
//   node format/js/gltf-transform/haha-gltf-transform.mjs IN.glb OUT.glb [options]
//
//   --mesh-compression draco|none  re-encode the body mesh with Draco (KHR_draco_mesh_compression,
//                                  edgebreaker, POSITION 16 / TEXCOORD 12 / NORMAL 10 bits) or
//                                  write plain accessors; default: as the input is
//   --draco-method edgebreaker|sequential  Draco's method (default edgebreaker: the faces and
//                                  vertices get reordered, which faceOrder "canonical" files allow)
//   --position-bits N             Draco position bits (default 16: fewer move the Gaussians'
//                                  faces, and the depth test is sensitive to sub-0.1 mm moves)
//   --reorder                     move the body mesh and node to the end of their lists (every
//                                  index the extension names changes; for tests)
//   --without-haha                do not register the extension (shows what glTF-Transform does
//                                  with an avatar otherwise: it drops the Gaussians)
//
// Prints one line: what was written. Exit 0, or 1 with a one-line error.
import fs from 'node:fs';
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS, KHRDracoMeshCompression } from '@gltf-transform/extensions';
import draco3d from 'draco3dgltf';
import { HAHA_EXTENSIONS, HAHA_GAUSSIAN_AVATAR } from './haha-gaussian-avatar.mjs';

const usage = 'usage: haha-gltf-transform.mjs IN.glb OUT.glb [--mesh-compression draco|none] [--draco-method edgebreaker|sequential] [--position-bits N] [--reorder] [--without-haha]';

function parse(argv) {
  const o = { files: [], meshCompression: null, dracoMethod: 'edgebreaker', positionBits: 16, reorder: false, withoutHaha: false };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === '--mesh-compression') {
      o.meshCompression = argv[++i];
      if (o.meshCompression !== 'draco' && o.meshCompression !== 'none') throw new Error(`--mesh-compression: '${o.meshCompression}' is not draco or none`);
    } else if (a === '--draco-method') {
      o.dracoMethod = argv[++i];
      if (o.dracoMethod !== 'edgebreaker' && o.dracoMethod !== 'sequential') throw new Error(`--draco-method: '${o.dracoMethod}' is not edgebreaker or sequential`);
    } else if (a === '--position-bits') {
      o.positionBits = Number(argv[++i]);
      if (!Number.isInteger(o.positionBits) || o.positionBits < 1 || o.positionBits > 30) throw new Error(`--position-bits: '${argv[i]}' is not 1..30`);
    } else if (a === '--reorder') o.reorder = true;
    else if (a === '--without-haha') o.withoutHaha = true;
    else if (a === '-h' || a === '--help') { console.log(usage); process.exit(0); }
    else if (a.startsWith('-')) throw new Error(`unknown option ${a} (${usage})`);
    else o.files.push(a);
  }
  if (o.files.length !== 2) throw new Error(usage);
  return o;
}

// Moves `property` to the end of the root's list of its kind (glTF-Transform writes each list
// in order), without touching what refers to it.
function moveToEnd(root, listName, property) {
  root.removeRef(listName, property);
  root.addRef(listName, property);
}

async function main() {
  const o = parse(process.argv.slice(2));
  const [input, output] = o.files;
  if (!fs.existsSync(input)) throw new Error(`${input}: no such file`);
  const extensions = o.withoutHaha ? ALL_EXTENSIONS : [...ALL_EXTENSIONS, ...HAHA_EXTENSIONS];
  const io = new NodeIO().registerExtensions(extensions).registerDependencies({
    'draco3d.decoder': await draco3d.createDecoderModule(),
    'draco3d.encoder': await draco3d.createEncoderModule(),
  });
  // glTF-Transform's own warnings (e.g. an unregistered extension) go to stderr.
  const doc = await io.read(input);
  const root = doc.getRoot();
  const avatar = root.getExtension(HAHA_GAUSSIAN_AVATAR);

  if (o.reorder) {
    if (!avatar) throw new Error('--reorder needs the HAHA_gaussian_avatar extension');
    moveToEnd(root, 'meshes', avatar.getBodyMesh());
    moveToEnd(root, 'nodes', avatar.getBodyNode());
  }

  const usedDraco = root.listExtensionsUsed().find((e) => e.extensionName === 'KHR_draco_mesh_compression');
  const draco = o.meshCompression ? o.meshCompression === 'draco' : Boolean(usedDraco);
  if (draco) {
    (usedDraco || doc.createExtension(KHRDracoMeshCompression)).setRequired(true).setEncoderOptions({
      method: KHRDracoMeshCompression.EncoderMethod[o.dracoMethod.toUpperCase()],
      encodeSpeed: 5,
      decodeSpeed: 5,
      quantizationBits: { POSITION: o.positionBits, NORMAL: 10, TEX_COORD: 12, COLOR: 8, GENERIC: 12 },
    });
  } else if (usedDraco) {
    usedDraco.dispose();
  }
  await io.write(output, doc);
  const bytes = fs.statSync(output).size;
  console.log(`${output}: ${bytes} B, body mesh ${draco ? `Draco ${o.dracoMethod}` : 'plain'}, ` +
              `${avatar && !o.withoutHaha ? `${HAHA_GAUSSIAN_AVATAR} kept (${avatar.listPayloads().length} payloads)` : `no ${HAHA_GAUSSIAN_AVATAR}`}`);
}

main().catch((e) => {
  console.error(`haha-gltf-transform: ${e.message}`);
  process.exit(1);
});
