#include "io/npy.h"

#include <zip.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {
namespace {

int dtype_size(DType t) {
  switch (t) {
    case DType::f32: case DType::i32: case DType::u32: return 4;
    case DType::f64: case DType::i64: return 8;
    default: return 0;
  }
}

const char* dtype_descr(DType t) {
  switch (t) {
    case DType::f32: return "<f4";
    case DType::f64: return "<f8";
    case DType::i32: return "<i4";
    case DType::u32: return "<u4";
    case DType::i64: return "<i8";
    default: return "";
  }
}

DType parse_descr(const std::string& d) {
  // '<' little-endian, '|' not applicable (single byte), '=' native (x86 = little).
  if (d.size() < 3 || (d[0] != '<' && d[0] != '=' && d[0] != '|')) return DType::unsupported;
  const std::string k = d.substr(1);
  if (k == "f4") return DType::f32;
  if (k == "f8") return DType::f64;
  if (k == "i4") return DType::i32;
  if (k == "u4") return DType::u32;
  if (k == "i8") return DType::i64;
  return DType::unsupported;
}

// Bytes per element of a fixed-width string descr: '<U8' (UTF-32) 32, '|S8' 8; else 0.
int64_t text_width(const std::string& d) {
  if (d.size() < 3 || d.size() > 12 || (d[1] != 'U' && d[1] != 'S')) return 0;
  if (d[0] != '<' && d[0] != '|' && d[0] != '=') return 0;
  int64_t n = 0;
  for (size_t i = 2; i < d.size(); ++i) {
    if (d[i] < '0' || d[i] > '9') return 0;
    n = n * 10 + (d[i] - '0');
  }
  return d[1] == 'U' ? 4 * n : n;
}

// Value of `key` in the header dict, e.g. 'descr': '<f4' -> "'<f4'".
std::string header_value(const std::string& h, const std::string& key, const std::string& where) {
  const std::string k = "'" + key + "'";
  size_t p = h.find(k);
  if (p == std::string::npos) fail(where, "npy header lacks '" + key + "'");
  p = h.find(':', p + k.size());
  if (p == std::string::npos) fail(where, "malformed npy header");
  ++p;
  while (p < h.size() && h[p] == ' ') ++p;
  size_t e = p;
  if (h[p] == '(') {
    e = h.find(')', p);
    if (e == std::string::npos) fail(where, "malformed npy shape");
    return h.substr(p, e - p + 1);
  }
  if (h[p] == '\'' || h[p] == '"') {
    e = h.find(h[p], p + 1);
    if (e == std::string::npos) fail(where, "malformed npy header string");
    return h.substr(p + 1, e - p - 1);
  }
  while (e < h.size() && h[e] != ',' && h[e] != '}') ++e;
  return h.substr(p, e - p);
}

template <class T>
void transpose_fortran(std::vector<uint8_t>& bytes, const std::vector<int64_t>& shape) {
  // Fortran order: first index varies fastest. Re-lay out in C order.
  const int64_t n = int64_t(bytes.size() / sizeof(T));
  std::vector<uint8_t> out(bytes.size());
  const int nd = int(shape.size());
  std::vector<int64_t> idx(nd, 0);
  for (int64_t f = 0; f < n; ++f) {
    // f enumerates Fortran order: idx[0] fastest.
    int64_t c = 0;
    for (int d = 0; d < nd; ++d) c = c * shape[d] + idx[d];
    std::memcpy(out.data() + c * sizeof(T), bytes.data() + f * sizeof(T), sizeof(T));
    for (int d = 0; d < nd; ++d) {
      if (++idx[d] < shape[d]) break;
      idx[d] = 0;
    }
  }
  bytes.swap(out);
}

template <class Src, class Dst>
std::vector<Dst> convert(const NpyArray& a) {
  const int64_t n = a.size();
  std::vector<Dst> out(static_cast<size_t>(n));
  const uint8_t* p = a.bytes.data();
  for (int64_t i = 0; i < n; ++i) {
    Src v;
    std::memcpy(&v, p + i * sizeof(Src), sizeof(Src));
    out[size_t(i)] = Dst(v);
  }
  return out;
}

template <class Dst>
std::vector<Dst> convert_any(const NpyArray& a) {
  switch (a.dtype) {
    case DType::f32: return convert<float, Dst>(a);
    case DType::f64: return convert<double, Dst>(a);
    case DType::i32: return convert<int32_t, Dst>(a);
    case DType::u32: return convert<uint32_t, Dst>(a);
    case DType::i64: return convert<int64_t, Dst>(a);
    default: throw Error("unsupported dtype '" + a.descr + "'");
  }
}

template <class T>
NpyArray make_array(const std::vector<T>& v, std::vector<int64_t> shape, DType t) {
  NpyArray a;
  a.dtype = t;
  a.descr = dtype_descr(t);
  a.shape = std::move(shape);
  if (a.size() != int64_t(v.size())) throw Error("npy: shape " + shape_string(a.shape) + " does not match " +
                                                 std::to_string(v.size()) + " values");
  a.bytes.resize(v.size() * sizeof(T));
  if (!v.empty()) std::memcpy(a.bytes.data(), v.data(), a.bytes.size());
  return a;
}

std::vector<uint8_t> read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open");
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

}  // namespace

std::string shape_string(const std::vector<int64_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) s += ",";
  return s + ")";
}

int64_t NpyArray::size() const {  // saturates: a listed-only array's shape is not bounded by data
  unsigned __int128 n = 1;
  for (int64_t d : shape) n = std::min<unsigned __int128>(n * uint64_t(std::max<int64_t>(d, 0)), INT64_MAX);
  return int64_t(n);
}

std::vector<float> NpyArray::as_float() const { return convert_any<float>(*this); }
std::vector<double> NpyArray::as_double() const { return convert_any<double>(*this); }
std::vector<int32_t> NpyArray::as_int32() const {
  if (dtype == DType::f32 || dtype == DType::f64) throw Error("expected integers, got '" + descr + "'");
  auto wide = convert_any<int64_t>(*this);  // exact for every integer dtype we decode
  std::vector<int32_t> out(wide.size());
  for (size_t i = 0; i < wide.size(); ++i) {
    if (wide[i] < std::numeric_limits<int32_t>::min() || wide[i] > std::numeric_limits<int32_t>::max())
      throw Error("integer value " + std::to_string(wide[i]) + " out of int32 range");
    out[i] = int32_t(wide[i]);
  }
  return out;
}

NpyArray NpyArray::from(const std::vector<float>& v, std::vector<int64_t> s) { return make_array(v, std::move(s), DType::f32); }
NpyArray NpyArray::from(const std::vector<double>& v, std::vector<int64_t> s) { return make_array(v, std::move(s), DType::f64); }
NpyArray NpyArray::from(const std::vector<int32_t>& v, std::vector<int64_t> s) { return make_array(v, std::move(s), DType::i32); }
NpyArray NpyArray::from(const std::vector<int64_t>& v, std::vector<int64_t> s) { return make_array(v, std::move(s), DType::i64); }

NpyArray parse_npy(const uint8_t* data, size_t size, const std::string& where) {
  static const char magic[] = "\x93NUMPY";
  if (size < 10 || std::memcmp(data, magic, 6) != 0) fail(where, "not an .npy array (bad magic)");
  const int major = data[6];
  size_t header_len, offset;
  if (major == 1) {
    header_len = size_t(data[8]) | (size_t(data[9]) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (size < 12) fail(where, "truncated .npy header");
    header_len = size_t(data[8]) | (size_t(data[9]) << 8) | (size_t(data[10]) << 16) | (size_t(data[11]) << 24);
    offset = 12;
  } else {
    fail(where, "unsupported .npy version " + std::to_string(major));
  }
  if (offset + header_len > size) fail(where, "truncated .npy header");
  const std::string h(reinterpret_cast<const char*>(data + offset), header_len);
  NpyArray a;
  a.descr = header_value(h, "descr", where);
  a.dtype = parse_descr(a.descr);
  const std::string fortran = header_value(h, "fortran_order", where);
  const std::string shape = header_value(h, "shape", where);
  // "(3, 4)" / "(5,)" / "()". Dimensions are bounded so their product cannot overflow;
  // the data the shape needs is checked against what the buffer holds before any copy.
  constexpr int64_t kMaxDim = int64_t(1) << 40;
  std::string num;
  for (char c : shape) {
    if (c >= '0' && c <= '9') {
      num += c;
      if (num.size() > 13) fail(where, "npy shape '" + shape + "': dimension too large");
    } else if (c == ',' || c == ')') {
      if (!num.empty()) {
        const int64_t d = std::stoll(num);
        if (d > kMaxDim) fail(where, "npy shape '" + shape + "': dimension too large");
        a.shape.push_back(d);
        if (a.shape.size() > 32) fail(where, "npy shape '" + shape + "': more than 32 dimensions");
      }
      num.clear();
    } else if (c != '(' && c != ' ' && c != 'L') {
      fail(where, "malformed npy shape '" + shape + "'");
    }
  }
  const size_t body = offset + header_len;
  const size_t have = size - body;
  if (a.dtype == DType::unsupported) {
    // Listed, not decoded (object arrays etc.). A single fixed-width string ('<U8', '|S8',
    // e.g. AMASS's gender) keeps its bytes for npy_text().
    const int64_t width = text_width(a.descr);
    if (width > 0 && a.shape.size() <= 1 && (a.shape.empty() || a.shape[0] == 1) && uint64_t(width) <= have)
      a.bytes.assign(data + body, data + body + width);
    return a;
  }
  const size_t esize = size_t(dtype_size(a.dtype));
  unsigned __int128 count = 1;  // elements; clamped once past what the data could hold
  for (int64_t d : a.shape) count = std::min<unsigned __int128>(count * uint64_t(d), have + 1);
  if (count * esize > have)
    fail(where, "truncated .npy data: shape " + shape_string(a.shape) + " needs more than the " + std::to_string(have) +
                    " bytes the file has");
  const size_t nbytes = size_t(count) * esize;
  a.bytes.assign(data + body, data + body + nbytes);
  if (fortran.find("True") != std::string::npos && a.shape.size() > 1) {
    if (dtype_size(a.dtype) == 4) transpose_fortran<uint32_t>(a.bytes, a.shape);
    else transpose_fortran<uint64_t>(a.bytes, a.shape);
  }
  return a;
}

std::vector<uint8_t> serialize_npy(const NpyArray& a) {
  const bool text = a.dtype == DType::unsupported && text_width(a.descr) > 0 && int64_t(a.bytes.size()) == text_width(a.descr);
  if (a.dtype == DType::unsupported && !text) throw Error("npy: cannot write unsupported dtype '" + a.descr + "'");
  std::string h = "{'descr': '" + (text ? a.descr : std::string(dtype_descr(a.dtype))) + "', 'fortran_order': False, 'shape': " +
                  shape_string(a.shape) + ", }";
  // Pad so that data starts on a 64-byte boundary; header ends with '\n'.
  const size_t total = 10 + h.size() + 1;
  h.append((64 - total % 64) % 64, ' ');
  h += '\n';
  const uint8_t pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, uint8_t(h.size() & 0xff), uint8_t(h.size() >> 8)};
  std::vector<uint8_t> out(10 + h.size() + a.bytes.size());
  std::memcpy(out.data(), pre, 10);
  std::memcpy(out.data() + 10, h.data(), h.size());
  if (!a.bytes.empty()) std::memcpy(out.data() + 10 + h.size(), a.bytes.data(), a.bytes.size());
  return out;
}

NpyArray read_npy(const std::string& path) {
  auto bytes = read_file(path);
  NpyArray a = parse_npy(bytes.data(), bytes.size(), path);
  if (a.dtype == DType::unsupported) fail(path, "unsupported dtype '" + a.descr + "'");
  return a;
}

void write_npy(const std::string& path, const NpyArray& a) {
  auto bytes = serialize_npy(a);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!f) fail(path, "write failed");
  });
}

Npz Npz::read(const std::string& path) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z) {
    zip_error_t ze;
    zip_error_init_with_code(&ze, err);
    std::string msg = zip_error_strerror(&ze);
    zip_error_fini(&ze);
    fail(path, "cannot open as .npz: " + msg);
  }
  Npz npz(path);
  std::error_code size_error;
  const uint64_t archive_bytes = std::filesystem::file_size(path, size_error);
  try {
    if (size_error) fail(path, "cannot read its size");
    const zip_int64_t n = zip_get_num_entries(z, 0);
    for (zip_int64_t i = 0; i < n; ++i) {
      zip_stat_t st;
      if (zip_stat_index(z, zip_uint64_t(i), 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME) ||
          !(st.valid & ZIP_STAT_SIZE) || !(st.valid & ZIP_STAT_COMP_SIZE))
        fail(path, "corrupt zip directory");
      std::string name = st.name;
      if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
      const std::string where = path + ": " + name;
      // The directory's sizes are only claims: the compressed bytes must lie in the file,
      // and the uncompressed size must be what they can produce (deflate expands at most
      // ~1032:1), before anything is allocated for it.
      if (st.comp_size > archive_bytes)
        fail(where, "archive member claims " + std::to_string(st.comp_size) + " compressed bytes in a " +
                        std::to_string(archive_bytes) + "-byte file (corrupt or hostile)");
      if (st.size > st.comp_size * 1100 + 4096)
        fail(where, "archive member claims " + std::to_string(st.size) + " bytes from " +
                        std::to_string(st.comp_size) + " compressed bytes (corrupt or hostile)");
      zip_file_t* zf = zip_fopen_index(z, zip_uint64_t(i), 0);
      if (!zf) fail(where, "cannot read archive member");
      std::vector<uint8_t> buf(st.size);
      const zip_int64_t got = st.size ? zip_fread(zf, buf.data(), st.size) : 0;
      zip_fclose(zf);
      if (got < 0 || zip_uint64_t(got) != st.size) fail(where, "truncated or corrupt archive member");
      NpyArray a = parse_npy(buf.data(), buf.size(), where);
      if (a.dtype == DType::unsupported) {
        npz.undecodable_[name] = "unsupported dtype '" + a.descr + "'";
        if (!a.bytes.empty()) npz.texts_[name] = npy_text(a);
      } else
        npz.arrays_[name] = std::move(a);
    }
  } catch (...) {
    zip_discard(z);
    throw;
  }
  zip_discard(z);
  return npz;
}

bool Npz::has(const std::string& key) const { return arrays_.count(key) > 0; }

const NpyArray& Npz::get(const std::string& key) const {
  auto it = arrays_.find(key);
  if (it != arrays_.end()) return it->second;
  auto bad = undecodable_.find(key);
  if (bad != undecodable_.end()) fail(path_ + ": " + key, bad->second);
  fail(path_ + ": " + key, "missing");
}

const NpyArray& Npz::get(const std::string& key, const std::vector<int64_t>& shape) const {
  const NpyArray& a = get(key);
  bool ok = a.shape.size() == shape.size();
  for (size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || shape[i] == a.shape[i];
  if (!ok) {
    std::string want = "(";
    for (size_t i = 0; i < shape.size(); ++i) want += (i ? ", " : "") + (shape[i] < 0 ? std::string("*") : std::to_string(shape[i]));
    want += shape.size() == 1 ? ",)" : ")";
    fail(path_ + ": " + key, "wrong shape " + shape_string(a.shape) + ", expected " + want);
  }
  return a;
}

NpyArray NpyArray::text(const std::string& s) {
  NpyArray a;
  a.descr = "<U" + std::to_string(std::max<size_t>(s.size(), 1));
  a.bytes.assign(4 * std::max<size_t>(s.size(), 1), 0);
  for (size_t i = 0; i < s.size(); ++i) a.bytes[4 * i] = uint8_t(s[i]);
  return a;
}

std::string npy_text(const NpyArray& a) {
  const int64_t width = text_width(a.descr);
  if (width <= 0 || int64_t(a.bytes.size()) != width) return {};
  std::string out;
  if (a.descr[1] == 'S') {
    for (uint8_t c : a.bytes) if (c) out += char(c);
  } else {  // UTF-32LE; only ASCII is kept (model names, genders)
    for (size_t i = 0; i + 3 < a.bytes.size(); i += 4) {
      const uint32_t c = uint32_t(a.bytes[i]) | uint32_t(a.bytes[i + 1]) << 8 | uint32_t(a.bytes[i + 2]) << 16 |
                         uint32_t(a.bytes[i + 3]) << 24;
      if (c && c < 128) out += char(c);
    }
  }
  return out;
}

bool Npz::has_text(const std::string& key) const { return texts_.count(key) > 0; }

std::string Npz::text(const std::string& key) const {
  auto it = texts_.find(key);
  if (it != texts_.end()) return it->second;
  if (arrays_.count(key) || undecodable_.count(key)) fail(path_ + ": " + key, "not a single string");
  fail(path_ + ": " + key, "missing");
}

std::vector<std::string> Npz::keys() const {
  std::vector<std::string> k;
  for (auto& [name, a] : arrays_) k.push_back(name);
  for (auto& [name, r] : undecodable_) k.push_back(name);
  return k;
}

void Npz::write(const std::string& path) const {
  write_atomically(path, [&](const std::string& tmp) {
    int err = 0;
    zip_t* z = zip_open(tmp.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
    if (!z) fail(path, "cannot create archive");
    std::vector<std::vector<uint8_t>> keep;  // libzip reads buffers at close time
    keep.reserve(arrays_.size());
    for (auto& [name, a] : arrays_) {
      keep.push_back(serialize_npy(a));
      zip_source_t* src = zip_source_buffer(z, keep.back().data(), keep.back().size(), 0);
      if (!src) { zip_discard(z); fail(path, "cannot add " + name); }
      const zip_int64_t idx = zip_file_add(z, (name + ".npy").c_str(), src, ZIP_FL_OVERWRITE);
      if (idx < 0) { zip_source_free(src); zip_discard(z); fail(path, "cannot add " + name); }
      zip_set_file_compression(z, zip_uint64_t(idx), ZIP_CM_DEFLATE, 1);
      zip_file_set_mtime(z, zip_uint64_t(idx), 0, 0);  // byte-identical files for identical arrays
    }
    if (zip_close(z) != 0) {
      std::string msg = zip_strerror(z);
      zip_discard(z);
      fail(path, "cannot write archive: " + msg);
    }
  });
}

std::vector<double> npz_numbers(const Npz& z, const std::string& key, const std::vector<int64_t>& shape) {
  const NpyArray& a = z.get(key, shape);
  std::vector<double> v;
  try {
    v = a.as_double();
  } catch (const Error& e) {
    fail(z.path() + ": " + key, e.what());
  }
  for (double d : v)
    if (!std::isfinite(d)) fail(z.path() + ": " + key, "non-finite value");
  return v;
}

double npz_scalar(const Npz& z, const std::string& key) {
  const NpyArray& a = z.get(key);
  if (a.size() != 1) fail(z.path() + ": " + key, "expected a single number, found shape " + shape_string(a.shape));
  return npz_numbers(z, key, a.shape)[0];
}

}  // namespace haha
