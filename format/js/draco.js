// The Draco decode function avatar.js takes, over an Emscripten Draco decoder module
// (draco3d / draco3dgltf, or three.js's examples/jsm/libs/draco/draco_decoder.js /
// draco_wasm_wrapper.js): decode(bytes, ids, types) -> { index (faces, or null), [name]:
// TypedArray }, attributes fetched by unique id (GENERIC attributes included) as the named
// typed array type. Synchronous underneath (no worker); engine-free.
//
//   const module = await DracoDecoderModule({ wasmBinary });   // or require('draco3dgltf')...
//   const decode = dracoDecode(module);

const DATA_TYPE = {
  Float32Array: 'DT_FLOAT32', Int8Array: 'DT_INT8', Int16Array: 'DT_INT16', Int32Array: 'DT_INT32',
  Uint8Array: 'DT_UINT8', Uint16Array: 'DT_UINT16', Uint32Array: 'DT_UINT32',
};
const ARRAYS = { Float32Array, Int8Array, Int16Array, Int32Array, Uint8Array, Uint16Array, Uint32Array };

export function dracoDecode(draco) {
  return async (bytes, ids, types) => {
    const decoder = new draco.Decoder();
    const array = new Int8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    let geom = null;
    try {
      const kind = decoder.GetEncodedGeometryType(array);
      let status;
      if (kind === draco.TRIANGULAR_MESH) {
        geom = new draco.Mesh();
        status = decoder.DecodeArrayToMesh(array, array.byteLength, geom);
      } else if (kind === draco.POINT_CLOUD) {
        geom = new draco.PointCloud();
        status = decoder.DecodeArrayToPointCloud(array, array.byteLength, geom);
      } else {
        throw new Error('Draco: unknown geometry type');
      }
      if (!status.ok() || geom.ptr === 0) throw new Error(`Draco: decoding failed: ${status.error_msg()}`);
      const out = { index: null };
      const points = geom.num_points();
      if (kind === draco.TRIANGULAR_MESH) {
        const n = geom.num_faces() * 3, byteLength = n * 4;
        const ptr = draco._malloc(byteLength);
        decoder.GetTrianglesUInt32Array(geom, byteLength, ptr);
        out.index = new Uint32Array(draco.HEAPF32.buffer, ptr, n).slice();
        draco._free(ptr);
      }
      for (const name of Object.keys(ids)) {
        const Type = ARRAYS[types[name]];
        if (!Type) throw new Error(`Draco: unknown array type ${types[name]}`);
        const attr = decoder.GetAttributeByUniqueId(geom, ids[name]);
        if (!attr || attr.ptr === 0) throw new Error(`Draco: no attribute with unique id ${ids[name]} (${name})`);
        const n = points * attr.num_components(), byteLength = n * Type.BYTES_PER_ELEMENT;
        const ptr = draco._malloc(byteLength);
        decoder.GetAttributeDataArrayForAllPoints(geom, attr, draco[DATA_TYPE[types[name]]], byteLength, ptr);
        out[name] = new Type(draco.HEAPF32.buffer, ptr, n).slice();
        draco._free(ptr);
      }
      return out;
    } finally {
      if (geom) draco.destroy(geom);
      draco.destroy(decoder);
    }
  };
}
