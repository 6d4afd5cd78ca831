#include "format/draco_io.h"

#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/mesh/mesh.h>
#include <draco/point_cloud/point_cloud.h>

#include <cstring>

#include "core/error.h"

namespace haha::dracoio {

namespace {

draco::DataType to_draco(Type t) {
  switch (t) {
    case Type::f32: return draco::DT_FLOAT32;
    case Type::i32: return draco::DT_INT32;
    case Type::u8: return draco::DT_UINT8;
    case Type::u16: return draco::DT_UINT16;
    case Type::u32: return draco::DT_UINT32;
  }
  return draco::DT_INVALID;
}

size_t type_size(Type t) {
  switch (t) {
    case Type::f32: case Type::i32: case Type::u32: return 4;
    case Type::u16: return 2;
    case Type::u8: return 1;
  }
  return 0;
}

draco::GeometryAttribute::Type to_draco(Kind k) {
  switch (k) {
    case Kind::position: return draco::GeometryAttribute::POSITION;
    case Kind::normal: return draco::GeometryAttribute::NORMAL;
    case Kind::texcoord: return draco::GeometryAttribute::TEX_COORD;
    case Kind::color: return draco::GeometryAttribute::COLOR;
    case Kind::generic: return draco::GeometryAttribute::GENERIC;
  }
  return draco::GeometryAttribute::GENERIC;
}

}  // namespace

Encoded encode(int num_points, const std::vector<AttrIn>& attrs, const int32_t* faces, int num_faces, Method method) {
  const std::string where = "draco encode";
  std::unique_ptr<draco::PointCloud> pc;
  draco::Mesh* mesh = nullptr;
  if (faces) {
    auto m = std::make_unique<draco::Mesh>();
    mesh = m.get();
    pc = std::move(m);
  } else {
    pc = std::make_unique<draco::PointCloud>();
  }
  pc->set_num_points(uint32_t(num_points));
  Encoded enc;
  for (const AttrIn& a : attrs) {
    if (a.components < 1 || a.components > 16) fail(where, a.name + ": bad component count");
    draco::GeometryAttribute ga;
    const size_t stride = type_size(a.type) * size_t(a.components);
    ga.Init(to_draco(a.kind), nullptr, uint8_t(a.components), to_draco(a.type), a.normalized, int64_t(stride), 0);
    // Identity mapping: point i owns value i, nothing is deduplicated or reordered.
    const int id = pc->AddAttribute(ga, true, uint32_t(num_points));
    if (id < 0) fail(where, a.name + ": Draco could not add the attribute");
    draco::PointAttribute* pa = pc->attribute(id);
    if (num_points > 0) std::memcpy(pa->buffer()->data(), a.data, stride * size_t(num_points));
    enc.unique_ids.push_back(int(pa->unique_id()));
  }
  if (mesh) {
    mesh->SetNumFaces(size_t(num_faces));
    for (int f = 0; f < num_faces; ++f) {
      draco::Mesh::Face face;
      for (int c = 0; c < 3; ++c) face[c] = draco::PointIndex(uint32_t(faces[3 * f + c]));
      mesh->SetFace(draco::FaceIndex(uint32_t(f)), face);
    }
  }
  std::unique_ptr<draco::ExpertEncoder> encoder =
      mesh ? std::make_unique<draco::ExpertEncoder>(*mesh) : std::make_unique<draco::ExpertEncoder>(*pc);
  const int draco_method = !mesh ? int(draco::POINT_CLOUD_SEQUENTIAL_ENCODING)
                           : method == Method::edgebreaker ? int(draco::MESH_EDGEBREAKER_ENCODING)
                                                           : int(draco::MESH_SEQUENTIAL_ENCODING);
  encoder->SetEncodingMethod(draco_method);
  // Slowest encoder / decoder settings = best entropy coding; decoding stays fast.
  encoder->SetSpeedOptions(0, 0);
  for (size_t i = 0; i < attrs.size(); ++i) {
    if (attrs[i].quant_bits > 0) {
      if (attrs[i].type != Type::f32) fail(where, attrs[i].name + ": quantization applies to float attributes only");
      if (attrs[i].quant_bits > 30) fail(where, attrs[i].name + ": quantization bits must be 1..30");
      encoder->SetAttributeQuantization(int32_t(i), attrs[i].quant_bits);
    }
    if (!attrs[i].predict) {
      const draco::Status ps = encoder->SetAttributePredictionScheme(int32_t(i), draco::PREDICTION_NONE);
      if (!ps.ok()) fail(where, attrs[i].name + ": " + ps.error_msg());
    }
  }
  draco::EncoderBuffer buffer;
  const draco::Status st = encoder->EncodeToBuffer(&buffer);
  if (!st.ok()) fail(where, std::string("Draco failed: ") + st.error_msg());
  enc.bytes.assign(buffer.data(), buffer.data() + buffer.size());
  return enc;
}

StreamHeader peek(const uint8_t* data, size_t size, const std::string& where, const std::string& what) {
  if (size < 11 || std::memcmp(data, "DRACO", 5) != 0) fail(where, what + ": not a Draco stream");
  StreamHeader h;
  if (data[7] > 1) fail(where, what + ": unknown Draco geometry type");
  h.mesh = data[7] == 1;
  // Draco 1.5 writes meshes as bitstream 2.2 and point clouds as 2.3.
  const int minor = h.mesh ? 2 : 3;
  if (data[5] != 2 || data[6] != minor) {
    fail(where, what + ": Draco bitstream version " + std::to_string(data[5]) + "." + std::to_string(data[6]) +
                    " (this reader expects 2." + std::to_string(minor) + ")");
  }
  // Method byte: 0 sequential, 1 edgebreaker (meshes only; point clouds must keep their order).
  if (data[8] > 1 || (data[8] == 1 && !h.mesh)) {
    fail(where, what + (h.mesh ? ": unknown Draco mesh encoding" : ": not Draco's sequential encoding (point clouds must keep their order)"));
  }
  h.method = data[8] == 1 ? Method::edgebreaker : Method::sequential;
  if ((data[9] | (data[10] << 8)) & 0x8000) fail(where, what + ": unexpected Draco metadata");
  size_t pos = 11;
  auto varint = [&]() {
    uint64_t v = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      if (pos >= size) fail(where, what + ": truncated Draco header");
      const uint8_t b = data[pos++];
      v |= uint64_t(b & 0x7F) << shift;
      if (!(b & 0x80)) {
        if (v > 0xFFFFFFFFull) break;
        return uint32_t(v);
      }
    }
    fail(where, what + ": corrupt Draco header");
  };
  if (h.mesh && h.method == Method::edgebreaker) {
    // Traverser: 0 standard, 2 valence (1, the deprecated predictive one, is refused).
    if (pos >= size) fail(where, what + ": truncated Draco header");
    const uint8_t traverser = data[pos++];
    if (traverser != 0 && traverser != 2) fail(where, what + ": unsupported Draco edgebreaker traversal " + std::to_string(traverser));
    h.num_points = varint();
    h.num_faces = varint();
  } else if (h.mesh) {
    h.num_faces = varint();
    h.num_points = varint();
  } else {
    if (pos + 4 > size) fail(where, what + ": truncated Draco header");
    int32_t n;
    std::memcpy(&n, data + pos, 4);
    if (n < 0) fail(where, what + ": corrupt Draco header (negative point count)");
    h.num_points = uint32_t(n);
  }
  if (uint64_t(h.num_points) > kMaxPointsPerByte * size + 4096) {
    fail(where, what + ": Draco header claims " + std::to_string(h.num_points) + " points in " + std::to_string(size) +
                    " bytes (corrupt)");
  }
  if (uint64_t(h.num_faces) > kMaxPointsPerByte * size + 4096) {
    fail(where, what + ": Draco header claims " + std::to_string(h.num_faces) + " faces in " + std::to_string(size) +
                    " bytes (corrupt)");
  }
  return h;
}

Decoded::Decoded(const uint8_t* data, size_t size, bool expect_mesh, std::string where, std::string what,
                 int64_t expected_points, int64_t expected_faces)
    : where_(std::move(where)), what_(std::move(what)) {
  const StreamHeader h = peek(data, size, where_, what_);
  method_ = h.method;
  if (h.mesh != expect_mesh) fail(where_, what_ + (expect_mesh ? ": Draco stream is not a triangle mesh" : ": Draco stream is not a point cloud"));
  // A point cloud's header holds its point count. A mesh's holds the connectivity's
  // vertices, which an encoder that merged equal values (glTF-Transform's) keeps below the
  // decoded points (corners split again where an attribute differs): at most the count
  // here, exactly it once decoded.
  auto wrong_count = [&](int64_t n) {
    fail(where_, what_ + ": Draco stream has " + std::to_string(n) + " points, the file says " + std::to_string(expected_points));
  };
  if (expected_points >= 0 && (expect_mesh ? int64_t(h.num_points) > expected_points : int64_t(h.num_points) != expected_points)) {
    wrong_count(int64_t(h.num_points));
  }
  if (expected_faces >= 0 && int64_t(h.num_faces) != expected_faces) {
    fail(where_, what_ + ": Draco stream has " + std::to_string(h.num_faces) + " faces, the file says " + std::to_string(expected_faces));
  }
  draco::DecoderBuffer buf;
  buf.Init(reinterpret_cast<const char*>(data), size);
  auto type = draco::Decoder::GetEncodedGeometryType(&buf);
  if (!type.ok()) fail(where_, what_ + ": Draco stream does not decode: " + type.status().error_msg());
  if (expect_mesh && type.value() != draco::TRIANGULAR_MESH) fail(where_, what_ + ": Draco stream is not a triangle mesh");
  if (!expect_mesh && type.value() != draco::POINT_CLOUD) fail(where_, what_ + ": Draco stream is not a point cloud");
  draco::Decoder decoder;
  if (expect_mesh) {
    auto r = decoder.DecodeMeshFromBuffer(&buf);
    if (!r.ok()) fail(where_, what_ + ": Draco stream does not decode: " + r.status().error_msg());
    std::unique_ptr<draco::Mesh> m = std::move(r).value();
    if (!m) fail(where_, what_ + ": Draco stream does not decode");
    mesh_ = m.get();
    pc_ = std::move(m);
    if (expected_points >= 0 && int64_t(pc_->num_points()) != expected_points) wrong_count(int64_t(pc_->num_points()));
  } else {
    auto r = decoder.DecodePointCloudFromBuffer(&buf);
    if (!r.ok()) fail(where_, what_ + ": Draco stream does not decode: " + r.status().error_msg());
    pc_ = std::move(r).value();
    if (!pc_) fail(where_, what_ + ": Draco stream does not decode");
  }
}

Decoded::~Decoded() = default;
Decoded::Decoded(Decoded&&) noexcept = default;

int Decoded::num_points() const { return int(pc_->num_points()); }
int Decoded::num_faces() const { return mesh_ ? int(mesh_->num_faces()) : 0; }

std::vector<int32_t> Decoded::faces() const {
  std::vector<int32_t> out;
  if (!mesh_) return out;
  const uint32_t n = mesh_->num_faces();
  out.resize(size_t(n) * 3);
  for (uint32_t f = 0; f < n; ++f) {
    const auto& face = mesh_->face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) {
      const uint32_t p = face[c].value();
      if (p >= pc_->num_points()) fail(where_, what_ + ": face " + std::to_string(f) + " refers to a missing point");
      out[3 * f + c] = int32_t(p);
    }
  }
  return out;
}

const void* Decoded::attribute(int unique_id, int components, const std::string& name) const {
  if (unique_id < 0) fail(where_, what_ + ": " + name + ": bad Draco attribute id");
  const draco::PointAttribute* a = pc_->GetAttributeByUniqueId(uint32_t(unique_id));
  if (!a) fail(where_, what_ + ": " + name + ": Draco attribute " + std::to_string(unique_id) + " is missing");
  if (a->num_components() != components) {
    fail(where_, what_ + ": " + name + ": " + std::to_string(a->num_components()) + " components, expected " +
                     std::to_string(components));
  }
  const size_t n = pc_->num_points();
  if (n > 0) {
    if (!a->buffer()) fail(where_, what_ + ": " + name + ": no data");
    const int64_t stride = int64_t(components) * draco::DataTypeLength(a->data_type());
    if (a->byte_stride() != stride || a->byte_offset() != 0) fail(where_, what_ + ": " + name + ": unexpected layout");
    const size_t need = a->size() * size_t(stride);
    if (a->buffer()->data_size() < need) fail(where_, what_ + ": " + name + ": truncated attribute data");
  }
  return a;
}

bool Decoded::is_float(int unique_id) const {
  const draco::PointAttribute* a = pc_->GetAttributeByUniqueId(uint32_t(unique_id));
  return a && a->data_type() == draco::DT_FLOAT32;
}

std::vector<float> Decoded::floats(int unique_id, int components, const std::string& name) const {
  const auto* a = static_cast<const draco::PointAttribute*>(attribute(unique_id, components, name));
  if (a->data_type() != draco::DT_FLOAT32) fail(where_, what_ + ": " + name + ": expected float32 values");
  const size_t n = pc_->num_points();
  std::vector<float> out(n * size_t(components));
  for (size_t i = 0; i < n; ++i) {
    const draco::AttributeValueIndex v = a->mapped_index(draco::PointIndex(uint32_t(i)));
    if (v.value() >= a->size()) fail(where_, what_ + ": " + name + ": point " + std::to_string(i) + " has no value");
    std::memcpy(&out[i * size_t(components)], a->GetAddress(v), sizeof(float) * size_t(components));
  }
  return out;
}

std::vector<int64_t> Decoded::ints(int unique_id, int components, const std::string& name) const {
  const auto* a = static_cast<const draco::PointAttribute*>(attribute(unique_id, components, name));
  const draco::DataType t = a->data_type();
  if (t != draco::DT_INT32 && t != draco::DT_UINT32 && t != draco::DT_UINT16 && t != draco::DT_UINT8 &&
      t != draco::DT_INT16 && t != draco::DT_INT8) {
    fail(where_, what_ + ": " + name + ": expected integer values");
  }
  const size_t n = pc_->num_points();
  std::vector<int64_t> out(n * size_t(components));
  for (size_t i = 0; i < n; ++i) {
    const draco::AttributeValueIndex v = a->mapped_index(draco::PointIndex(uint32_t(i)));
    if (v.value() >= a->size()) fail(where_, what_ + ": " + name + ": point " + std::to_string(i) + " has no value");
    if (!a->ConvertValue<int64_t>(v, int8_t(components), &out[i * size_t(components)])) {
      fail(where_, what_ + ": " + name + ": unreadable value");
    }
  }
  return out;
}

}  // namespace haha::dracoio
