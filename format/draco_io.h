// Draco encode/decode for the avatar format (internal to haha_format). Point clouds use
// Draco's SEQUENTIAL method (it keeps point order). Meshes use SEQUENTIAL (face and point
// order kept: lossless and version-1 files) or EDGEBREAKER (about 3x smaller; it reorders
// points and faces and rotates each face's corners, so the packer records what the
// Gaussians need: format/spec.md, "faceCorner").
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace draco {
class PointCloud;
class Mesh;
}  // namespace draco

namespace haha::dracoio {

enum class Kind { position, normal, texcoord, color, generic };
enum class Type { f32, i32, u8, u16, u32 };
enum class Method { sequential, edgebreaker };

// One attribute to encode: `components` values per point, `count` points, tightly packed.
struct AttrIn {
  std::string name;  // for errors and stats
  Kind kind = Kind::generic;
  Type type = Type::f32;
  int components = 1;
  const void* data = nullptr;
  int quant_bits = 0;  // float attributes only; 0 = stored as raw float32 (lossless)
  // Let Draco predict values (delta coding of consecutive values for sequential streams).
  // Off for attributes whose consecutive values are unrelated: the delta of two independent
  // values costs more bits than the value.
  bool predict = true;
  // Integers that stand for [0, 1] (glTF's normalized accessors, e.g. skin weights): the
  // stream says so too, as decoders that read its flag expect.
  bool normalized = false;
};

struct Encoded {
  std::vector<uint8_t> bytes;
  std::vector<int> unique_ids;  // per AttrIn, the Draco attribute unique id
};

// faces == nullptr: a point cloud (always sequential); else a triangle mesh with
// `num_faces` faces, encoded with `method`. Throws haha::Error (where = "draco encode") if
// Draco refuses.
Encoded encode(int num_points, const std::vector<AttrIn>& attrs, const int32_t* faces, int num_faces,
               Method method = Method::sequential);

// What the header of a Draco stream claims, read without decoding it. Only the bitstream
// this project writes is accepted: Draco 1.5's bitstream (mesh 2.2, point cloud 2.3),
// sequential point clouds, sequential or edgebreaker (standard or valence) meshes, no
// metadata.
struct StreamHeader {
  bool mesh = false;
  Method method = Method::sequential;
  uint32_t num_points = 0;  // edgebreaker: the connectivity's vertex count (= points in our files)
  uint32_t num_faces = 0;   // meshes only
};
// Throws haha::Error "<where>: <what>: ..." if the header is not of that form.
StreamHeader peek(const uint8_t* data, size_t size, const std::string& where, const std::string& what);

// Largest point count accepted per byte of stream. Draco's point-cloud decoder trusts the
// count in the stream and allocates for it, so a corrupt count could exhaust memory; even a
// cloud of identical points costs more than 1/10 byte per point (measured 0.12 B).
inline constexpr uint64_t kMaxPointsPerByte = 16;

// A decoded Draco stream. Every accessor checks type, component count and sizes and
// throws haha::Error "<where>: <what>: <problem>" on mismatch. `expected_points` /
// `expected_faces` (>= 0) are checked against the stream's header BEFORE decoding (a mesh's
// header may count fewer points: its connectivity's vertices; then the decoded count must
// match).
class Decoded {
 public:
  Decoded(const uint8_t* data, size_t size, bool expect_mesh, std::string where, std::string what,
          int64_t expected_points = -1, int64_t expected_faces = -1);
  ~Decoded();
  Decoded(Decoded&&) noexcept;
  int num_points() const;
  int num_faces() const;                 // 0 for a point cloud
  Method method() const { return method_; }
  std::vector<int32_t> faces() const;    // (F, 3) point indices, checked < num_points
  // Values of the attribute with this unique id, `components` per point, converted from
  // the stored integer/float type. `expect` lists the acceptable stored types.
  std::vector<float> floats(int unique_id, int components, const std::string& name) const;
  std::vector<int64_t> ints(int unique_id, int components, const std::string& name) const;
  // Whether the stored attribute was quantized (for reporting).
  bool is_float(int unique_id) const;

 private:
  const void* attribute(int unique_id, int components, const std::string& name) const;
  std::unique_ptr<draco::PointCloud> pc_;
  const draco::Mesh* mesh_ = nullptr;
  std::string where_, what_;
  Method method_ = Method::sequential;
};

}  // namespace haha::dracoio
