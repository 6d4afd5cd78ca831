// Binary glTF (.glb) container: JSON chunk, BIN chunk, bufferViews, CRC-32 (format/spec.md
// section 3: every `crc32` field is the CRC-32 (IEEE, as zlib/PNG) of the named bufferView).

const CRC_TABLE = (() => {
  const t = new Uint32Array(256);
  for (let n = 0; n < 256; n++) {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    t[n] = c >>> 0;
  }
  return t;
})();

export function crc32(bytes) {
  let c = 0xffffffff;
  for (let i = 0; i < bytes.length; i++) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

const COMPONENTS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4, MAT2: 4, MAT3: 9, MAT4: 16 };
const COMPONENT_TYPES = {  // glTF componentType -> [bytes, DataView getter, normalization divisor]
  5120: [1, 'getInt8', 127], 5121: [1, 'getUint8', 255], 5122: [2, 'getInt16', 32767],
  5123: [2, 'getUint16', 65535], 5125: [4, 'getUint32', 4294967295], 5126: [4, 'getFloat32', 0],
};

export class Glb {
  // The JSON and BIN chunk of an already parsed file (e.g. from a glTF loader).
  static fromParts(json, bin, name = 'avatar.glb') {
    const g = Object.create(Glb.prototype);
    g.name = name;
    g.json = json;
    g.bin = bin instanceof Uint8Array ? bin : new Uint8Array(bin || new ArrayBuffer(0));
    return g;
  }

  // buffer: ArrayBuffer of the whole file; name: for error messages.
  constructor(buffer, name = 'avatar.glb') {
    this.name = name;
    const dv = new DataView(buffer);
    const fail = (msg) => { throw new Error(`${name}: ${msg}`); };
    if (buffer.byteLength < 20 || dv.getUint32(0, true) !== 0x46546c67) fail('not a binary glTF (.glb) file');
    if (dv.getUint32(4, true) !== 2) fail(`glTF version ${dv.getUint32(4, true)}, expected 2`);
    const total = dv.getUint32(8, true);
    if (total > buffer.byteLength) fail('truncated');
    let off = 12;
    this.json = null;
    this.bin = null;
    while (off + 8 <= total) {
      const len = dv.getUint32(off, true), type = dv.getUint32(off + 4, true);
      if (off + 8 + len > total) fail('chunk runs past the end of the file');
      const body = new Uint8Array(buffer, off + 8, len);
      if (type === 0x4e4f534a) this.json = JSON.parse(new TextDecoder().decode(body));
      else if (type === 0x004e4942) this.bin = body;
      off += 8 + len;
    }
    if (!this.json) fail('no JSON chunk');
    if (!this.bin) fail('no BIN chunk');
  }

  // Bytes of bufferView i (a view into the file; copy before transferring).
  view(i) {
    const bv = (this.json.bufferViews || [])[i];
    if (!bv) throw new Error(`${this.name}: bufferView ${i} does not exist`);
    if ((bv.buffer || 0) !== 0) throw new Error(`${this.name}: bufferView ${i} is not in the GLB's BIN chunk`);
    const o = bv.byteOffset || 0;
    if (o + bv.byteLength > this.bin.length) throw new Error(`${this.name}: bufferView ${i} lies outside the BIN chunk`);
    return this.bin.subarray(o, o + bv.byteLength);
  }

  // bufferView i after checking its CRC-32 against `crc` (what: for the error message).
  checkedView(i, crc, what) {
    const bytes = this.view(i);
    if (crc !== undefined && crc32(bytes) !== crc >>> 0) {
      throw new Error(`${this.name}: ${what}: CRC-32 mismatch (file damaged)`);
    }
    return bytes;
  }

  // Accessor i as { count, comps, componentType, normalized, values: Float64Array (count x
  // comps) }: byteOffset, byteStride (interleaved views), normalized integers (decoded to
  // [0, 1] / [-1, 1] as glTF defines), sparse substitution, no bufferView (zeros).
  // comps: the expected components per element (0: any). what: for error messages.
  readAccessor(i, comps = 0, what = `accessor ${i}`) {
    const fail = (m) => { throw new Error(`${this.name}: ${what}: ${m}`); };
    const acc = (this.json.accessors || [])[i];
    if (!acc || typeof acc !== 'object') fail(`accessor ${i} does not exist`);
    const n = COMPONENTS[acc.type];
    const ct = COMPONENT_TYPES[acc.componentType];
    if (!n) fail(`unknown accessor type ${acc.type}`);
    if (!ct) fail(`unknown componentType ${acc.componentType}`);
    if (comps && n !== comps) fail(`${acc.type} accessor, expected ${comps} components`);
    const count = acc.count;
    if (!Number.isInteger(count) || count < 0) fail('bad count');
    const [size, getter, full] = ct;
    const norm = acc.normalized === true && full > 0;
    if (acc.normalized === true && !full) fail('a normalized float accessor');
    const values = new Float64Array(count * n);
    const read = (bytes, off, stride, k, out, at) => {
      const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
      for (let e = 0; e < k; e++) {
        for (let c = 0; c < n; c++) {
          let x = dv[getter](off + e * stride + c * size, true);
          if (norm) x = Math.max(x / full, -1);
          out[(at ? at[e] : e) * n + c] = x;
        }
      }
    };
    const elem = size * n;
    if (acc.bufferView !== undefined) {
      const bytes = this.view(acc.bufferView);
      const bv = this.json.bufferViews[acc.bufferView];
      const stride = bv.byteStride || elem;
      const off = acc.byteOffset || 0;
      if (stride < elem) fail(`byteStride ${stride} smaller than an element (${elem} B)`);
      if (count > 0 && off + (count - 1) * stride + elem > bytes.length) fail('runs past its bufferView');
      if (off % size || stride % size) fail('misaligned');
      read(bytes, off, stride, count, values);
    }
    if (acc.sparse) {
      const sp = acc.sparse, k = sp.count;
      if (!Number.isInteger(k) || k < 1 || k > count) fail('bad sparse count');
      const it = COMPONENT_TYPES[sp.indices.componentType];
      if (!it || sp.indices.componentType === 5126) fail('bad sparse index type');
      const ib = this.view(sp.indices.bufferView), io = sp.indices.byteOffset || 0;
      if (io + k * it[0] > ib.length) fail('sparse indices run past their bufferView');
      const idv = new DataView(ib.buffer, ib.byteOffset, ib.byteLength);
      const at = new Array(k);
      for (let e = 0; e < k; e++) {
        at[e] = idv[it[1]](io + e * it[0], true);
        if (at[e] >= count) fail(`sparse index ${at[e]} out of range`);
      }
      const vb = this.view(sp.values.bufferView), vo = sp.values.byteOffset || 0;
      if (vo + k * elem > vb.length) fail('sparse values run past their bufferView');
      read(vb, vo, elem, k, values, at);
    }
    return { count, comps: n, componentType: acc.componentType, normalized: norm, values };
  }
}
