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

export class Glb {
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
}
