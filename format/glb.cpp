#include "format/glb.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "core/error.h"

namespace haha::glb {

namespace {

constexpr uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

std::array<uint32_t, 256> make_crc_table() {
  std::array<uint32_t, 256> t{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}

uint32_t read_u32(const uint8_t* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
void put_u32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

uint32_t crc32(const uint8_t* data, size_t size) {
  static const std::array<uint32_t, 256> table = make_crc_table();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

int BinWriter::add_view(const void* data, size_t size, int align, int target, int byte_stride) {
  while (bin_.size() % size_t(align)) bin_.push_back(0);
  const size_t offset = bin_.size();
  const auto* p = static_cast<const uint8_t*>(data);
  bin_.insert(bin_.end(), p, p + size);
  Json v = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", size}};
  if (target > 0) v["target"] = target;
  if (byte_stride > 0) v["byteStride"] = byte_stride;
  views_.push_back(v);
  sizes_.push_back(size);
  crcs_.push_back(crc32(p, size));
  return int(views_.size()) - 1;
}

std::vector<uint8_t> write_glb(const Json& gltf, const std::vector<uint8_t>& bin) {
  std::string js = gltf.dump();
  while (js.size() % 4) js.push_back(' ');
  const size_t bin_padded = (bin.size() + 3) / 4 * 4;
  const size_t total = 12 + 8 + js.size() + (bin.empty() ? 0 : 8 + bin_padded);
  std::vector<uint8_t> out;
  out.reserve(total);
  put_u32(out, kMagic);
  put_u32(out, 2);
  put_u32(out, uint32_t(total));
  put_u32(out, uint32_t(js.size()));
  put_u32(out, kChunkJson);
  out.insert(out.end(), js.begin(), js.end());
  if (!bin.empty()) {
    put_u32(out, uint32_t(bin_padded));
    put_u32(out, kChunkBin);
    out.insert(out.end(), bin.begin(), bin.end());
    out.resize(total, 0);
  }
  return out;
}

Glb parse_glb(const uint8_t* data, size_t size, const std::string& where) {
  if (size < 20) fail(where, "not a .glb file: " + std::to_string(size) + " bytes is shorter than a GLB header");
  if (read_u32(data) != kMagic) fail(where, "not a .glb file (bad magic)");
  const uint32_t version = read_u32(data + 4);
  if (version != 2) fail(where, "unsupported GLB container version " + std::to_string(version) + " (need 2)");
  const uint32_t length = read_u32(data + 8);
  if (length > size) {
    fail(where, "truncated: header says " + std::to_string(length) + " bytes, file has " + std::to_string(size));
  }
  if (length < 20) fail(where, "corrupt GLB header (length " + std::to_string(length) + ")");
  Glb g;
  size_t pos = 12;
  bool have_json = false, have_bin = false;
  while (pos + 8 <= length) {
    const uint32_t clen = read_u32(data + pos);
    const uint32_t ctype = read_u32(data + pos + 4);
    pos += 8;
    if (clen > length - pos) fail(where, "truncated or corrupt GLB chunk (length " + std::to_string(clen) + ")");
    if (!have_json) {
      if (ctype != kChunkJson) fail(where, "corrupt GLB: first chunk is not JSON");
      try {
        g.json = Json::parse(data + pos, data + pos + clen);
      } catch (const Json::exception& e) {
        fail(where, std::string("corrupt glTF JSON: ") + e.what());
      }
      g.json_chunk_bytes = clen;
      have_json = true;
    } else if (ctype == kChunkBin && !have_bin) {
      g.bin.assign(data + pos, data + pos + clen);
      have_bin = true;
    }  // other chunk types are ignored, as the GLB spec requires
    pos += clen;
    pos = (pos + 3) / 4 * 4;
  }
  if (!have_json) fail(where, "corrupt GLB: no JSON chunk");
  if (!g.json.is_object()) fail(where, "corrupt glTF JSON: top level is not an object");
  return g;
}

const Json* find_member(const Json& obj, const char* key) {
  if (!obj.is_object()) return nullptr;
  auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

const Json& member(const Json& obj, const char* key, const std::string& where, const std::string& what) {
  if (!obj.is_object()) fail(where, what + ": not a JSON object");
  auto it = obj.find(key);
  if (it == obj.end()) fail(where, what + "." + key + ": missing");
  return *it;
}

int64_t as_int(const Json& v, const std::string& where, const std::string& what, int64_t lo, int64_t hi) {
  int64_t x = 0;
  if (v.is_number_integer()) {
    x = v.is_number_unsigned() ? (v.get<uint64_t>() > uint64_t(INT64_MAX) ? INT64_MAX : int64_t(v.get<uint64_t>()))
                               : v.get<int64_t>();
  } else if (v.is_number_float()) {
    const double d = v.get<double>();
    if (!std::isfinite(d) || d != std::floor(d) || std::fabs(d) > 9e15) fail(where, what + ": not an integer");
    x = int64_t(d);
  } else {
    fail(where, what + ": not an integer");
  }
  if (x < lo || x > hi) {
    fail(where, what + ": " + std::to_string(x) + " out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return x;
}

double as_number(const Json& v, const std::string& where, const std::string& what) {
  if (!v.is_number()) fail(where, what + ": not a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail(where, what + ": not finite");
  return d;
}

std::string as_string(const Json& v, const std::string& where, const std::string& what) {
  if (!v.is_string()) fail(where, what + ": not a string");
  return v.get<std::string>();
}

std::vector<float> as_float_array(const Json& v, const std::string& where, const std::string& what,
                                  size_t max_len) {
  if (!v.is_array()) fail(where, what + ": not an array");
  if (v.size() > max_len) fail(where, what + ": " + std::to_string(v.size()) + " values, at most " + std::to_string(max_len));
  std::vector<float> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    const double d = as_number(v[i], where, what + "[" + std::to_string(i) + "]");
    const float f = float(d);
    if (!std::isfinite(f)) fail(where, what + "[" + std::to_string(i) + "]: out of float range");
    out.push_back(f);
  }
  return out;
}

double json_float(float f) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, f, std::chars_format::scientific);  // fixed prints every digit of large values
  *r.ptr = 0;
  const double d = std::strtod(buf, nullptr);
  // Rounding the decimal to double and then to float could in principle land on a tie the
  // decimal alone would not; the exact double is the fallback.
  return float(d) == f ? d : double(f);
}

const Json& element(const Json& root, const char* key, int64_t i, const std::string& where) {
  const Json& arr = member(root, key, where, "glTF");
  if (!arr.is_array()) fail(where, std::string(key) + ": not an array");
  if (i < 0 || size_t(i) >= arr.size()) {
    fail(where, std::string(key) + "[" + std::to_string(i) + "]: index out of range (" + std::to_string(arr.size()) + " entries)");
  }
  return arr[size_t(i)];
}

ByteSpan buffer_view(const Glb& g, int view, const std::string& where) {
  const Json& bv = element(g.json, "bufferViews", view, where);
  const std::string what = "bufferViews[" + std::to_string(view) + "]";
  const int64_t buffer = as_int(member(bv, "buffer", where, what), where, what + ".buffer", 0, 1 << 20);
  if (buffer != 0) fail(where, what + ": refers to buffer " + std::to_string(buffer) + ", only the GLB buffer 0 is supported");
  const Json& b0 = element(g.json, "buffers", 0, where);
  if (find_member(b0, "uri")) fail(where, "buffers[0]: external buffers are not supported (expected the GLB BIN chunk)");
  int64_t offset = 0;
  if (const Json* o = find_member(bv, "byteOffset")) offset = as_int(*o, where, what + ".byteOffset", 0, INT64_MAX / 4);
  const int64_t length = as_int(member(bv, "byteLength", where, what), where, what + ".byteLength", 0, INT64_MAX / 4);
  if (size_t(offset) > g.bin.size() || size_t(length) > g.bin.size() - size_t(offset)) {
    fail(where, what + ": bytes [" + std::to_string(offset) + ", " + std::to_string(offset + length) +
                    ") lie outside the " + std::to_string(g.bin.size()) + "-byte BIN chunk (truncated file?)");
  }
  return {g.bin.data() + offset, size_t(length)};
}

AccessorValues read_accessor(const Glb& g, int64_t index, int components, const std::string& where, const std::string& what) {
  const Json& acc = element(g.json, "accessors", index, where);
  const std::string A = what + " (accessors[" + std::to_string(index) + "])";
  if (find_member(acc, "sparse")) fail(where, A + ": sparse accessors are not supported");
  const Json* bv = find_member(acc, "bufferView");
  if (!bv) fail(where, A + ": no bufferView");
  AccessorValues out;
  out.component_type = int(as_int(member(acc, "componentType", where, A), where, A + ".componentType", 5120, 5126));
  static const int kSize[7] = {1, 1, 2, 2, 0, 4, 4};  // 5120 byte .. 5126 float (5124 does not exist)
  const int size = kSize[out.component_type - 5120];
  if (size == 0) fail(where, A + ": unknown componentType 5124");
  if (const Json* n = find_member(acc, "normalized")) {
    if (!n->is_boolean()) fail(where, A + ".normalized: not a boolean");
    out.normalized = n->get<bool>();
  }
  if (out.normalized && (out.component_type == 5125 || out.component_type == 5126)) fail(where, A + ": normalized " + (out.component_type == 5126 ? "float" : "unsigned int"));
  static const char* const kTypes[] = {"SCALAR", "VEC2", "VEC3", "VEC4"};
  const std::string type = as_string(member(acc, "type", where, A), where, A + ".type");
  if (components < 1 || components > 4 || type != kTypes[components - 1]) fail(where, A + ": type " + type + ", expected " + kTypes[components - 1]);
  out.count = as_int(member(acc, "count", where, A), where, A + ".count", 1, INT64_MAX / 64);
  const int64_t view = as_int(*bv, where, A + ".bufferView", 0, INT32_MAX);
  const ByteSpan s = buffer_view(g, int(view), where);
  int64_t offset = 0, stride = int64_t(size) * components;
  if (const Json* o = find_member(acc, "byteOffset")) offset = as_int(*o, where, A + ".byteOffset", 0, INT32_MAX);
  const Json& bvj = element(g.json, "bufferViews", view, where);
  if (const Json* st = find_member(bvj, "byteStride")) stride = as_int(*st, where, "bufferViews[" + std::to_string(view) + "].byteStride", 4, 252);
  if (stride < int64_t(size) * components) fail(where, A + ": byteStride smaller than an element");
  // The range is checked before anything is allocated: the count must fit the bytes.
  const size_t elem = size_t(size) * size_t(components);
  if (size_t(offset) > s.size || s.size - size_t(offset) < elem || (s.size - size_t(offset) - elem) / size_t(stride) < size_t(out.count - 1)) {
    fail(where, A + ": " + std::to_string(out.count) + " elements do not fit its bufferView");
  }
  out.values.resize(size_t(out.count) * size_t(components));
  const double scale[7] = {127.0, 255.0, 32767.0, 65535.0, 1.0, 1.0, 1.0};
  for (int64_t e = 0; e < out.count; ++e)
    for (int c = 0; c < components; ++c) {
      const uint8_t* p = s.data + offset + e * stride + c * size;
      double v = 0;
      switch (out.component_type) {
        case 5120: { int8_t x; std::memcpy(&x, p, 1); v = x; break; }
        case 5121: { uint8_t x; std::memcpy(&x, p, 1); v = x; break; }
        case 5122: { int16_t x; std::memcpy(&x, p, 2); v = x; break; }
        case 5123: { uint16_t x; std::memcpy(&x, p, 2); v = x; break; }
        case 5125: { uint32_t x; std::memcpy(&x, p, 4); v = x; break; }
        default: { float x; std::memcpy(&x, p, 4); v = x; break; }
      }
      if (out.normalized) v = std::max(v / scale[out.component_type - 5120], -1.0);  // glTF's rule for signed types
      out.values[size_t(e) * components + size_t(c)] = v;
    }
  return out;
}

}  // namespace haha::glb
