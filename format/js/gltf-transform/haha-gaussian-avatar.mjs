// glTF-Transform (@gltf-transform/core 4.x) extension classes for HAHA avatars (format/spec.md):
//
//   HahaGaussianAvatar  HAHA_gaussian_avatar (root `extensions`): the face-bound Gaussians, pose
//                       correctives, exact texture and joint regressor (opaque bufferView payloads,
//                       kept as bytes) and the body mesh / node / skin / texture image and splat
//                       mesh / node (kept as glTF-Transform property references, so any index
//                       change a transform makes is followed on write).
//   KHRGaussianSplatting  KHR_gaussian_splatting on a primitive (`haha pack --khr-gaussian-splatting`):
//                       its JSON object passed through unchanged (glTF-Transform core keeps the
//                       primitive's attributes, but drops an unknown primitive extension).
//
// Register both (with the Khronos extensions and Draco) and a pipeline can read, transform and
// write an avatar that haha still loads:
//
//   import { NodeIO } from '@gltf-transform/core';
//   import { KHRONOS_EXTENSIONS } from '@gltf-transform/extensions';
//   import draco3d from 'draco3dgltf';
//   import { HAHA_EXTENSIONS } from './haha-gaussian-avatar.mjs';
//   const io = new NodeIO().registerExtensions([...KHRONOS_EXTENSIONS, ...HAHA_EXTENSIONS])
//     .registerDependencies({ 'draco3d.decoder': await draco3d.createDecoderModule(),
//                             'draco3d.encoder': await draco3d.createEncoderModule() });
//   const doc = await io.read('avatar.glb');  /* transform */  await io.write('out.glb', doc);
//
// On write: every payload gets a fresh bufferView (8-byte aligned) and its crc32 is recomputed
// (CRC-32 IEEE, as zlib); `texture.crc32` / `width` / `height` follow the image as written;
// `body.draco` and `body.garment.draco` are dropped (they described haha's own Draco streams;
// optional since version 3). Only version-3 and -4 files can be rewritten (version 4: a
// garment is the body mesh's primitive 1) (earlier versions keep the body-vertex map inside the
// Draco stream, which glTF-Transform does not keep), with `gaussians.faceOrder` "canonical" (the
// default pack: it survives any face and vertex reordering, Draco edgebreaker included; "file",
// lossless packs, names faces by their position in haha's own stream and is refused).
import { Accessor, Extension, ExtensionProperty, Format, GLB_BUFFER, ImageUtils, Primitive, PropertyType } from '@gltf-transform/core';

export const HAHA_GAUSSIAN_AVATAR = 'HAHA_gaussian_avatar';
export const KHR_GAUSSIAN_SPLATTING = 'KHR_gaussian_splatting';
/** Versions read (format/spec.md); only the last two can be written back (see above). */
export const HAHA_READ_VERSIONS = [1, 2, 3, 4];
export const HAHA_WRITE_VERSION = 4;
// The oldest version it writes back: version 3 (no garment primitive yet) needs nothing new.
export const HAHA_OLDEST_WRITE_VERSION = 3;

// ---------------------------------------------------------------------------------------------
// CRC-32 (IEEE 802.3, reflected, as zlib / PNG).

let crcTable = null;
/** CRC-32 (IEEE, as zlib's crc32) of a Uint8Array, as an unsigned 32-bit number. */
export function crc32(bytes) {
  if (!crcTable) {
    crcTable = new Uint32Array(256);
    for (let n = 0; n < 256; n++) {
      let c = n;
      for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
      crcTable[n] = c >>> 0;
    }
  }
  let c = 0xffffffff;
  for (let i = 0; i < bytes.length; i++) c = crcTable[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

// ---------------------------------------------------------------------------------------------
// JSON helpers. Payload slots are named by the JSON pointer of their bufferView key
// ("/gaussians/bufferView", "/gaussians/tiers/1/bufferView", "/body/poseCorrectives/mixingBufferView");
// the checksum key pairs with it: "bufferView" -> "crc32", "xBufferView" -> "xCrc32".

const isObject = (v) => v !== null && typeof v === 'object' && !Array.isArray(v);
const isIndex = (v) => Number.isInteger(v) && v >= 0;
const deepCopy = (v) => (v === undefined ? undefined : JSON.parse(JSON.stringify(v)));
const crcKeyOf = (key) => (key === 'bufferView' ? 'crc32' : key.replace(/BufferView$/, 'Crc32'));
const isViewKey = (key) => key === 'bufferView' || /[a-z]BufferView$/.test(key);
const pointerParts = (pointer) => pointer.split('/').slice(1).map((p) => p.replace(/~1/g, '/').replace(/~0/g, '~'));
const pointerOf = (parts) => '/' + parts.map((p) => String(p).replace(/~/g, '~0').replace(/\//g, '~1')).join('/');

// Every bufferView slot under `node`: [{ parts, parent, key, value }].
function findViewSlots(node, parts = [], out = []) {
  if (Array.isArray(node)) node.forEach((v, i) => findViewSlots(v, [...parts, i], out));
  else if (isObject(node)) {
    for (const [k, v] of Object.entries(node)) {
      if (isViewKey(k)) out.push({ parts: [...parts, k], parent: node, key: k, value: v });
      else findViewSlots(v, [...parts, k], out);
    }
  }
  return out;
}

function parentAt(root, parts) {
  let node = root;
  for (const p of parts.slice(0, -1)) {
    if (node === null || typeof node !== 'object' || !(p in node)) return null;
    node = node[p];
  }
  return node !== null && typeof node === 'object' ? node : null;
}

function fail(message) {
  throw new Error(`${HAHA_GAUSSIAN_AVATAR}: ${message}`);
}

// A float _BODY_VERTEX (whole numbers) becomes unsigned short / int, as the spec stores it:
// Draco quantizes float attributes (12 bits for generic ones in glTF-Transform), which would
// turn body-vertex indices into wrong ones; integers it keeps exactly.
function integerBodyVertex(mesh) {
  for (const prim of mesh ? mesh.listPrimitives() : []) integerPrimitiveBodyVertex(prim);  // the body's, a garment's
}

function integerPrimitiveBodyVertex(prim) {
  const acc = prim.getAttribute('_BODY_VERTEX');
  if (!acc || acc.getComponentType() !== Accessor.ComponentType.FLOAT || acc.getElementSize() !== 1) return;
  const a = acc.getArray();
  let max = 0;
  for (let i = 0; i < a.length; i++) {
    if (!(a[i] >= 0) || a[i] !== Math.floor(a[i]) || a[i] > 0xffffffff) return;  // not indices: left as is
    if (a[i] > max) max = a[i];
  }
  acc.setArray(max <= 0xffff ? Uint16Array.from(a) : Uint32Array.from(a)).setNormalized(false);
}

// ---------------------------------------------------------------------------------------------

/**
 * The avatar (root-level ExtensionProperty). `getData()` is the extension object without the
 * references and payload slots (version, counts, subject, quantization, ...); references are
 * getBodyMesh() / getBodyNode() / getBodySkin() / getTexture() / getSplatMesh() /
 * getSplatNode(); payloads are listPayloads() / getPayload(pointer) / setPayload(pointer, bytes).
 */
export class HahaAvatar extends ExtensionProperty {
  static EXTENSION_NAME = HAHA_GAUSSIAN_AVATAR;

  init() {
    this.extensionName = HAHA_GAUSSIAN_AVATAR;
    this.propertyType = 'HahaAvatar';
    this.parentTypes = [PropertyType.ROOT];
  }

  getDefaults() {
    return Object.assign(super.getDefaults(), {
      data: {},
      payloads: {},
      bodyMesh: null, bodyNode: null, bodySkin: null, texture: null, splatMesh: null, splatNode: null,
    });
  }

  /** The extension object without references and payload slots (a copy). */
  getData() { return deepCopy(this.get('data')); }
  setData(data) {
    if (!isObject(data)) fail('setData: not an object');
    return this.set('data', deepCopy(data));
  }
  getVersion() { return this.get('data').version; }

  getBodyMesh() { return this.getRef('bodyMesh'); }
  setBodyMesh(mesh) { return this.setRef('bodyMesh', mesh); }
  getBodyNode() { return this.getRef('bodyNode'); }
  setBodyNode(node) { return this.setRef('bodyNode', node); }
  getBodySkin() { return this.getRef('bodySkin'); }
  setBodySkin(skin) { return this.setRef('bodySkin', skin); }
  /** The texture image (glTF-Transform's Texture is a glTF image). */
  getTexture() { return this.getRef('texture'); }
  setTexture(texture) { return this.setRef('texture', texture); }
  getSplatMesh() { return this.getRef('splatMesh'); }
  setSplatMesh(mesh) { return this.setRef('splatMesh', mesh); }
  getSplatNode() { return this.getRef('splatNode'); }
  setSplatNode(node) { return this.setRef('splatNode', node); }

  /** JSON pointers of the payload slots, e.g. "/gaussians/bufferView". */
  listPayloads() { return Object.keys(this.get('payloads')); }
  /** The bytes of one payload (do not modify them in place; setPayload a new array). */
  getPayload(pointer) { return this.get('payloads')[pointer] || null; }
  /** Sets (or, with null, removes) a payload; its crc32 is computed on write. */
  setPayload(pointer, bytes) {
    if (typeof pointer !== 'string' || !pointer.startsWith('/') || !isViewKey(String(pointerParts(pointer).pop()))) {
      fail(`setPayload: '${pointer}' is not the JSON pointer of a bufferView key`);
    }
    if (bytes !== null && !(bytes instanceof Uint8Array)) fail('setPayload: bytes must be a Uint8Array');
    const payloads = { ...this.get('payloads') };
    if (bytes === null) delete payloads[pointer];
    else payloads[pointer] = bytes;
    return this.set('payloads', payloads);
  }
}

/** HAHA_gaussian_avatar for glTF-Transform: read and write (see the top of this file). */
export class HahaGaussianAvatar extends Extension {
  static EXTENSION_NAME = HAHA_GAUSSIAN_AVATAR;
  extensionName = HAHA_GAUSSIAN_AVATAR;

  createAvatar() { return new HahaAvatar(this.document.getGraph()); }
  /** The document's avatar, or null. */
  getAvatar() { return this.document.getRoot().getExtension(HAHA_GAUSSIAN_AVATAR); }

  read(context) {
    const json = context.jsonDoc.json;
    const def = json.extensions && json.extensions[HAHA_GAUSSIAN_AVATAR];
    if (def === undefined) return this;
    if (!isObject(def)) fail('the extension object is not a JSON object');
    if (!HAHA_READ_VERSIONS.includes(def.version)) {
      fail(`unsupported version ${JSON.stringify(def.version)} (this extension reads versions ${HAHA_READ_VERSIONS.join(', ')})`);
    }
    if ((json.extensionsRequired || []).includes(HAHA_GAUSSIAN_AVATAR)) this.setRequired(true);
    const data = deepCopy(def);
    const avatar = this.createAvatar();
    const body = data.body;
    if (!isObject(body)) fail('body: missing or not an object');

    const refIndex = (obj, key, list, kind, where) => {
      const i = obj[key];
      if (!isIndex(i) || i >= list.length) fail(`${where}.${key}: ${JSON.stringify(i)} is not an index into this file's ${list.length} ${kind}`);
      delete obj[key];
      return list[i];
    };
    avatar.setBodyMesh(refIndex(body, 'mesh', context.meshes, 'meshes', 'body'));
    avatar.setBodyNode(refIndex(body, 'node', context.nodes, 'nodes', 'body'));
    avatar.setBodySkin(refIndex(body, 'skin', context.skins, 'skins', 'body'));
    // body.draco (and body.garment.draco) described haha's Draco streams; glTF-Transform
    // decodes the mesh, so they are gone.
    delete body.draco;
    if (isObject(body.garment)) delete body.garment.draco;
    if (!isObject(data.texture)) fail('texture: missing or not an object');
    avatar.setTexture(refIndex(data.texture, 'image', context.textures, 'images', 'texture'));
    if (data.splats !== undefined) {
      if (!isObject(data.splats)) fail('splats: not an object');
      avatar.setSplatMesh(refIndex(data.splats, 'mesh', context.meshes, 'meshes', 'splats'));
      avatar.setSplatNode(refIndex(data.splats, 'node', context.nodes, 'nodes', 'splats'));
    }
    const views = json.bufferViews || [];
    for (const slot of findViewSlots(data)) {
      const where = pointerOf(slot.parts).slice(1).replace(/\//g, '.');
      if (!isIndex(slot.value) || slot.value >= views.length) {
        fail(`${where}: ${JSON.stringify(slot.value)} is not an index into this file's ${views.length} bufferViews`);
      }
      const bytes = context.bufferViews[slot.value];
      if (!bytes) fail(`${where}: bufferView ${slot.value} has no data`);
      // A copy: the view points into the whole file's buffer.
      avatar.setPayload(pointerOf(slot.parts), bytes.slice());
      delete slot.parent[slot.key];
      delete slot.parent[crcKeyOf(slot.key)];
    }
    delete data.texture.crc32;
    avatar.setData(data);
    integerBodyVertex(avatar.getBodyMesh());
    this.document.getRoot().setExtension(HAHA_GAUSSIAN_AVATAR, avatar);
    return this;
  }

  write(context) {
    const json = context.jsonDoc.json;
    const avatar = this.getAvatar();
    if (!avatar) {
      json.extensionsUsed = (json.extensionsUsed || []).filter((n) => n !== HAHA_GAUSSIAN_AVATAR);
      json.extensionsRequired = (json.extensionsRequired || []).filter((n) => n !== HAHA_GAUSSIAN_AVATAR);
      return this;
    }
    const data = avatar.getData();
    if (!(data.version >= HAHA_OLDEST_WRITE_VERSION && data.version <= HAHA_WRITE_VERSION)) {
      fail(`cannot write a version-${data.version} avatar: before version ${HAHA_WRITE_VERSION} the body-vertex map ` +
           'lives inside haha\'s own Draco stream, which glTF-Transform does not keep; repack it with haha pack ' +
           `(version ${HAHA_WRITE_VERSION})`);
    }
    const mesh = avatar.getBodyMesh(), node = avatar.getBodyNode(), skin = avatar.getBodySkin(), tex = avatar.getTexture();
    if (!mesh || !context.meshIndexMap.has(mesh)) fail('the body mesh was removed from the document');
    if (!node || !context.nodeIndexMap.has(node)) fail('the body node was removed from the document');
    if (!skin || !context.skinIndexMap.has(skin)) fail('the body skin was removed from the document');
    if (!tex || !context.imageIndexMap.has(tex)) fail('the texture image was removed from the document');
    this._checkBodyMesh(mesh, data);

    data.body.mesh = context.meshIndexMap.get(mesh);
    data.body.node = context.nodeIndexMap.get(node);
    data.body.skin = context.skinIndexMap.get(skin);
    delete data.body.draco;
    if (isObject(data.body.garment)) delete data.body.garment.draco;
    const image = tex.getImage();
    if (!image) fail('the texture image has no data');
    data.texture.image = context.imageIndexMap.get(tex);
    data.texture.crc32 = crc32(image);
    let size = null;
    try { size = ImageUtils.getSize(image, tex.getMimeType()); } catch { size = null; }
    if (size && size[0] > 0 && size[1] > 0) [data.texture.width, data.texture.height] = size;
    if (data.splats !== undefined) {
      const sm = avatar.getSplatMesh(), sn = avatar.getSplatNode();
      if (sm && sn && context.meshIndexMap.has(sm) && context.nodeIndexMap.has(sn)) {
        data.splats.mesh = context.meshIndexMap.get(sm);
        data.splats.node = context.nodeIndexMap.get(sn);
      } else {
        delete data.splats;  // the splat mesh or node was removed by a transform
      }
    }

    // Payloads: appended to the first buffer, each 8-byte aligned (readers may view float
    // arrays in place), with fresh bufferViews and checksums.
    const pointers = avatar.listPayloads();
    if (pointers.length) {
      const buffer = this.document.getRoot().listBuffers()[0];
      if (!buffer) fail('the document has no buffer to hold the payloads');
      const bufferIndex = context.bufferIndexMap.get(buffer);
      const bufferDef = json.buffers[bufferIndex];
      let uri;
      if (context.options.format === Format.GLB) {
        if (bufferIndex !== 0) fail('GLB: the payload buffer is not the first buffer');
        uri = GLB_BUFFER;
      } else {
        uri = bufferDef.uri || (bufferDef.uri = context.bufferURIGenerator.createURI(buffer, 'bin'));
      }
      const old = context.jsonDoc.resources[uri] || new Uint8Array(0);
      const parts = [old];
      let length = old.byteLength;
      json.bufferViews = json.bufferViews || [];
      for (const pointer of pointers) {
        const bytes = avatar.getPayload(pointer);
        const path = pointerParts(pointer);
        const key = path[path.length - 1];
        const parent = parentAt(data, path);
        if (!parent) fail(`payload ${pointer}: its object is not in the extension data`);
        const pad = (8 - (length % 8)) % 8;
        if (pad) { parts.push(new Uint8Array(pad)); length += pad; }
        json.bufferViews.push({ buffer: bufferIndex, byteOffset: length, byteLength: bytes.byteLength });
        parent[key] = json.bufferViews.length - 1;
        parent[crcKeyOf(key)] = crc32(bytes);
        parts.push(bytes);
        length += bytes.byteLength;
      }
      const out = new Uint8Array(length);
      let o = 0;
      for (const p of parts) { out.set(p, o); o += p.byteLength; }
      context.jsonDoc.resources[uri] = out;
      bufferDef.byteLength = length;
    }
    json.extensions = json.extensions || {};
    json.extensions[HAHA_GAUSSIAN_AVATAR] = data;
    return this;
  }

  // The body primitives (the body's, then a garment's) must still be what the Gaussians bind to.
  _checkBodyMesh(mesh, data) {
    const prims = mesh.listPrimitives();
    if (!prims.length) fail('the body mesh has no primitive');
    if (prims.length !== (isObject(data.body.garment) && data.version >= 4 ? 2 : 1)) {
      fail(`the body mesh has ${prims.length} primitives, the avatar ${data.body.garment ? 'a body and a garment' : 'one'}`);
    }
    let faces = 0;
    for (const prim of prims) {
      if (prim.getMode() !== Primitive.Mode.TRIANGLES) fail('a primitive of the body mesh is no longer a triangle list');
      const bodyVertex = prim.getAttribute('_BODY_VERTEX');
      if (!bodyVertex) fail('the body mesh lost its _BODY_VERTEX attribute (the Gaussians bind through it)');
      faces += (prim.getIndices() || bodyVertex).getCount() / 3;
    }
    if (Number.isInteger(data.body.faceCount) && faces !== data.body.faceCount) {
      fail(`the body mesh has ${faces} faces, the avatar ${data.body.faceCount} (a transform added or removed faces)`);
    }
    const order = data.gaussians && data.gaussians.faceOrder;
    if (order !== 'canonical') {
      // "file" (lossless packs): the Gaussians name faces by position in haha's own stream,
      // which only body.draco vouches for; haha rejects such a file once a tool rewrote the mesh.
      fail(`gaussians.faceOrder ${JSON.stringify(order)}: the Gaussians name faces by their position in haha's own ` +
           'mesh stream, so the file cannot be rewritten; repack without --lossless (faceOrder "canonical")');
    }
  }
}

// ---------------------------------------------------------------------------------------------

/** KHR_gaussian_splatting's primitive object (kernel, colorSpace, ...), kept as JSON. */
export class GaussianSplatting extends ExtensionProperty {
  static EXTENSION_NAME = KHR_GAUSSIAN_SPLATTING;

  init() {
    this.extensionName = KHR_GAUSSIAN_SPLATTING;
    this.propertyType = 'GaussianSplatting';
    this.parentTypes = [PropertyType.PRIMITIVE];
  }

  getDefaults() { return Object.assign(super.getDefaults(), { data: {} }); }
  getData() { return deepCopy(this.get('data')); }
  setData(data) {
    if (!isObject(data)) throw new Error(`${KHR_GAUSSIAN_SPLATTING}: setData: not an object`);
    return this.set('data', deepCopy(data));
  }
}

/** KHR_gaussian_splatting pass-through: keeps each primitive's extension object. */
export class KHRGaussianSplatting extends Extension {
  static EXTENSION_NAME = KHR_GAUSSIAN_SPLATTING;
  extensionName = KHR_GAUSSIAN_SPLATTING;

  createGaussianSplatting() { return new GaussianSplatting(this.document.getGraph()); }

  read(context) {
    const meshDefs = context.jsonDoc.json.meshes || [];
    meshDefs.forEach((meshDef, m) => {
      (meshDef.primitives || []).forEach((primDef, p) => {
        const def = primDef.extensions && primDef.extensions[KHR_GAUSSIAN_SPLATTING];
        if (def === undefined) return;
        if (!isObject(def)) throw new Error(`${KHR_GAUSSIAN_SPLATTING}: meshes[${m}].primitives[${p}]: not a JSON object`);
        const prim = context.meshes[m].listPrimitives()[p];
        prim.setExtension(KHR_GAUSSIAN_SPLATTING, this.createGaussianSplatting().setData(def));
      });
    });
    return this;
  }

  write(context) {
    const json = context.jsonDoc.json;
    let written = 0;
    for (const mesh of this.document.getRoot().listMeshes()) {
      const meshIndex = context.meshIndexMap.get(mesh);
      if (meshIndex === undefined) continue;
      mesh.listPrimitives().forEach((prim, p) => {
        const gs = prim.getExtension(KHR_GAUSSIAN_SPLATTING);
        if (!gs) return;
        const primDef = json.meshes[meshIndex].primitives[p];
        primDef.extensions = primDef.extensions || {};
        primDef.extensions[KHR_GAUSSIAN_SPLATTING] = gs.getData();
        written++;
      });
    }
    if (!written) {
      json.extensionsUsed = (json.extensionsUsed || []).filter((n) => n !== KHR_GAUSSIAN_SPLATTING);
      json.extensionsRequired = (json.extensionsRequired || []).filter((n) => n !== KHR_GAUSSIAN_SPLATTING);
    }
    return this;
  }
}

/** Both classes, for io.registerExtensions([...KHRONOS_EXTENSIONS, ...HAHA_EXTENSIONS]). */
export const HAHA_EXTENSIONS = [HahaGaussianAvatar, KHRGaussianSplatting];
