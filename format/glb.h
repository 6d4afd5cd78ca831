// The binary glTF (.glb) container and the JSON helpers the avatar format uses. Internal
// to haha_format (the public API is avatar_pack.h / avatar_unpack.h / avatar_loader.h).
//
// Reading is defensive: every length, index and type is checked before use and any
// problem becomes one haha::Error "<where>: <problem>", so a corrupt file can never make
// the reader index out of bounds.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace haha::glb {

using Json = nlohmann::json;

// CRC-32 (IEEE 802.3, the zlib/PNG polynomial) of a byte range.
uint32_t crc32(const uint8_t* data, size_t size);

// Builds the single binary buffer of a .glb and its bufferViews.
class BinWriter {
 public:
  // Appends `size` bytes (aligned to `align`, zero padding) as a new bufferView and
  // returns its index. `target` (34962 ARRAY_BUFFER / 34963 ELEMENT_ARRAY_BUFFER) and
  // `byte_stride` are written when > 0 (a stride only where elements are padded to glTF's
  // 4-byte vertex alignment; everything else is tightly packed).
  int add_view(const void* data, size_t size, int align = 4, int target = 0, int byte_stride = 0);
  const std::vector<uint8_t>& bytes() const { return bin_; }
  const Json& views() const { return views_; }
  size_t view_size(int view) const { return sizes_.at(size_t(view)); }
  uint32_t view_crc(int view) const { return crcs_.at(size_t(view)); }

 private:
  std::vector<uint8_t> bin_;
  Json views_ = Json::array();
  std::vector<size_t> sizes_;
  std::vector<uint32_t> crcs_;
};

// Serialises JSON + BIN into a .glb (JSON chunk padded with spaces, BIN with zeros).
std::vector<uint8_t> write_glb(const Json& gltf, const std::vector<uint8_t>& bin);

// A parsed .glb: the JSON document and the BIN chunk (may be empty).
struct Glb {
  Json json;
  std::vector<uint8_t> bin;
  size_t json_chunk_bytes = 0;  // including padding
};

// Checks magic, version 2, total length, chunk headers and lengths; parses the JSON.
Glb parse_glb(const uint8_t* data, size_t size, const std::string& where);

// A bounds-checked view of one bufferView's bytes inside the BIN chunk.
struct ByteSpan {
  const uint8_t* data = nullptr;
  size_t size = 0;
};
ByteSpan buffer_view(const Glb& g, int view, const std::string& where);

// Typed, checked JSON access. `what` names the value in errors ("accessors[3].count").
const Json& member(const Json& obj, const char* key, const std::string& where, const std::string& what);
const Json* find_member(const Json& obj, const char* key);  // null if absent or obj not an object
int64_t as_int(const Json& v, const std::string& where, const std::string& what, int64_t lo, int64_t hi);
double as_number(const Json& v, const std::string& where, const std::string& what);  // finite
std::string as_string(const Json& v, const std::string& where, const std::string& what);
std::vector<float> as_float_array(const Json& v, const std::string& where, const std::string& what,
                                  size_t max_len);

// A float32 as a JSON number: the double nearest the shortest decimal that reads back as the
// same float32. nlohmann then prints that decimal (at most 9 significant digits for over
// 99 % of values; a double's 17 otherwise), and a reader parsing it as double and rounding
// to float gets the value exactly.
double json_float(float f);

// The values of accessor `index`, `components` per element, read from its bufferView with
// byteOffset and byteStride, every byte range checked; normalized integers mapped to
// [0, 1], other integers as they are (doubles hold every glTF component type exactly).
// Sparse accessors and accessors without a bufferView are rejected with an error.
struct AccessorValues {
  int component_type = 0;  // 5120..5126
  bool normalized = false;
  int64_t count = 0;
  std::vector<double> values;  // (count, components)
};
AccessorValues read_accessor(const Glb& g, int64_t index, int components, const std::string& where, const std::string& what);

// Index `i` into the top-level array `key` (e.g. "accessors"), checked.
const Json& element(const Json& root, const char* key, int64_t i, const std::string& where);

}  // namespace haha::glb
