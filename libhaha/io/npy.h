// Reading and writing NumPy .npy arrays and .npz archives (zip of .npy, stored or
// deflated). Supported dtypes: float32, float64, int32, uint32, int64 (little-endian, C
// order; Fortran order is transposed on read). Arrays of other dtypes (object arrays in
// real SMPL-X files, strings) are listed but not decoded: asking for one is an error
// naming the file and key. A single fixed-width string ('<U8', '|S8', e.g. AMASS's gender)
// can be read as text (Npz::text).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace haha {

enum class DType { f32, f64, i32, u32, i64, unsupported };

// One array, values kept in their stored type; shape in C order.
struct NpyArray {
  DType dtype = DType::unsupported;
  std::string descr;           // numpy descr string, e.g. "<f4", "|O"
  std::vector<int64_t> shape;  // empty = scalar
  std::vector<uint8_t> bytes;  // raw little-endian values, C order

  int64_t size() const;  // number of elements
  int ndim() const { return int(shape.size()); }
  // Converted copies. Throw haha::Error if the dtype is unsupported or a conversion
  // would lose integers (int64 beyond int32 range for as_int32).
  std::vector<float> as_float() const;
  std::vector<double> as_double() const;
  std::vector<int32_t> as_int32() const;

  static NpyArray from(const std::vector<float>& v, std::vector<int64_t> shape);
  static NpyArray from(const std::vector<double>& v, std::vector<int64_t> shape);
  static NpyArray from(const std::vector<int32_t>& v, std::vector<int64_t> shape);
  static NpyArray from(const std::vector<int64_t>& v, std::vector<int64_t> shape);
  static NpyArray text(const std::string& ascii);  // shape (), numpy '<Un' (as np.array('male'))
};

// Parses one .npy buffer. `where` names it in errors ("file.npz: key").
NpyArray parse_npy(const uint8_t* data, size_t size, const std::string& where);
std::vector<uint8_t> serialize_npy(const NpyArray& a);

NpyArray read_npy(const std::string& path);
void write_npy(const std::string& path, const NpyArray& a);  // atomic

// An .npz archive read fully into memory. Keys are the member names without ".npy".
class Npz {
 public:
  static Npz read(const std::string& path);
  Npz() = default;
  explicit Npz(std::string path) : path_(std::move(path)) {}

  bool has(const std::string& key) const;
  // Throws "path: key: missing" if absent, "path: key: unsupported dtype ..." if the
  // array could not be decoded.
  const NpyArray& get(const std::string& key) const;
  // get() plus a shape check: every non-negative entry of `shape` must match;
  // -1 matches anything. Error names file, key, expected and actual shape.
  const NpyArray& get(const std::string& key, const std::vector<int64_t>& shape) const;
  std::vector<std::string> keys() const;
  const std::string& path() const { return path_; }
  // A key holding one fixed-width string (shape () or (1,)); ASCII characters only.
  bool has_text(const std::string& key) const;
  std::string text(const std::string& key) const;  // throws "path: key: missing" / "not a single string"

  void set(const std::string& key, NpyArray a) { arrays_[key] = std::move(a); }
  void write(const std::string& path) const;  // atomic; deflate-compressed

 private:
  std::string path_;
  std::map<std::string, NpyArray> arrays_;
  std::map<std::string, std::string> undecodable_;  // key -> reason
  std::map<std::string, std::string> texts_;        // decodable single strings
};

// The text of a single fixed-width string array (empty if it is not one).
std::string npy_text(const NpyArray& a);

std::string shape_string(const std::vector<int64_t>& shape);

// Numbers of an npz key with a shape check (-1 = any), as doubles; errors name the file
// and key, also for non-finite values.
std::vector<double> npz_numbers(const Npz& z, const std::string& key, const std::vector<int64_t>& shape);
// A scalar (shape () or (1,)) of an npz key.
double npz_scalar(const Npz& z, const std::string& key);

}  // namespace haha
