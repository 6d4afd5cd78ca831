#include "format/avatar_pack.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <array>
#include <map>
#include <sstream>
#include <memory>

#include "body/face_frames.h"
#include "body/joint_names.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "format/avatar_validate.h"
#include "format/canonical_faces.h"
#include "format/draco_io.h"
#include "format/gaussian_lod.h"
#include "format/glb.h"

namespace haha {

using glb::Json;

namespace {

constexpr int kFloat = 5126, kUByte = 5121, kUShort = 5123, kUInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

Json float_array(const float* v, size_t n) {
  Json a = Json::array();
  for (size_t i = 0; i < n; ++i) a.push_back(glb::json_float(v[i]));
  return a;
}

// One primitive's share of the body model: vertices [v0, v1) and faces [f0, f1). The body
// is primitive 0; a garment (body/garment.h) is primitive 1, so a glTF viewer shows it
// skinned on the body and a user can hide or swap it.
struct MeshPart {
  int v0 = 0, v1 = 0, f0 = 0, f1 = 0;
  int num_faces() const { return f1 - f0; }
};

std::vector<MeshPart> mesh_parts(const BodyModel& b) {
  if (!b.has_garment()) return {{0, b.num_verts, 0, b.num_faces}};
  return {{0, b.garment_first_vert, 0, b.garment_first_face}, {b.garment_first_vert, b.num_verts, b.garment_first_face, b.num_faces}};
}

// glTF vertices: one per distinct (body vertex, UV index) corner pair. The part's first
// glTF vertices are its body vertices in order (so unreferenced vertices survive too); seam
// duplicates follow in first-use order. `source` holds indices of the whole mesh.
struct SplitMesh {
  std::vector<int32_t> source;  // (Vg) body vertex of each glTF vertex
  std::vector<int32_t> uv_of;   // (Vg) UV index of each glTF vertex (-1: none)
  std::vector<int32_t> faces;   // (F, 3) glTF vertex per corner
};

SplitMesh split_at_seams(const BodyModel& b, const MeshPart& part) {
  SplitMesh s;
  const int n = part.v1 - part.v0;
  s.source.resize(size_t(n));
  s.uv_of.assign(size_t(n), -1);
  for (int v = 0; v < n; ++v) s.source[size_t(v)] = part.v0 + v;
  std::map<std::pair<int32_t, int32_t>, int32_t> extra;
  s.faces.resize(size_t(part.num_faces()) * 3);
  for (size_t c = 0; c < s.faces.size(); ++c) {
    const size_t at = size_t(part.f0) * 3 + c;
    const int32_t v = b.faces[at], t = b.ft[at], l = v - part.v0;
    if (l < 0 || l >= n) fail("avatar", "garment: a face joins the body's and the garment's vertices");
    int32_t g;
    if (s.uv_of[size_t(l)] < 0 || s.uv_of[size_t(l)] == t) {
      s.uv_of[size_t(l)] = t;
      g = l;
    } else {
      auto it = extra.find({v, t});
      if (it == extra.end()) {
        g = int32_t(s.source.size());
        extra.emplace(std::make_pair(v, t), g);
        s.source.push_back(v);
        s.uv_of.push_back(t);
      } else {
        g = it->second;
      }
    }
    s.faces[c] = g;
  }
  return s;
}

// Area-weighted vertex normals of the rest mesh (per body vertex).
std::vector<float> vertex_normals(const std::vector<float>& verts, const BodyModel& b) {
  std::vector<double> n(size_t(b.num_verts) * 3, 0.0);
  for (int f = 0; f < b.num_faces; ++f) {
    const int32_t* fv = &b.faces[size_t(f) * 3];
    Vec3d p[3];
    for (int c = 0; c < 3; ++c) p[c] = Vec3d(Vec3f::load(&verts[size_t(fv[c]) * 3]));
    const Vec3d fn = cross(p[1] - p[0], p[2] - p[0]);  // length = 2 x area
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) n[size_t(fv[c]) * 3 + k] += fn[k];
  }
  std::vector<float> out(n.size());
  for (int v = 0; v < b.num_verts; ++v) {
    Vec3d x(n[size_t(v) * 3], n[size_t(v) * 3 + 1], n[size_t(v) * 3 + 2]);
    const double l = norm(x);
    x = l > 0 ? x / l : Vec3d(0, 1, 0);
    for (int k = 0; k < 3; ++k) out[size_t(v) * 3 + k] = float(x[k]);
  }
  return out;
}

struct SkinSets {
  int sets = 0, max_influences = 0;
  std::vector<uint8_t> joints;    // (sets, V, 4)
  std::vector<float> weights;     // (sets, V, 4) lossless: float32 as trained
  std::vector<uint16_t> codes;    // (sets, V, 4) lossy: normalized unsigned shorts
};

// One vertex's weights (largest first) as normalized unsigned-short codes that sum to
// exactly 65535 (glTF's rule, so they sum to 1 after decoding): every weight but the
// largest is a multiple of 2^(16 - bits), together rounded to the multiple nearest their
// sum and shared by largest remainders (each within one step); the largest takes the rest
// (within half a step). `bits` 0 or >= 16: every code. `full`: the total (65535; 255 for
// 8-bit codes).
std::vector<uint16_t> weight_codes(const std::vector<std::pair<float, int>>& list, int bits, int full = 65535) {
  const double step = bits <= 0 || bits >= 16 ? 1.0 : double(1u << (16 - bits));
  double sum = 0;
  for (const auto& [w, j] : list) sum += w;
  std::vector<uint16_t> codes(list.size());
  std::vector<int64_t> m(list.size(), 0);
  std::vector<std::pair<double, size_t>> rest;
  double others = 0;
  int64_t given = 0;
  for (size_t i = 1; i < list.size(); ++i) {
    const double t = list[i].first / sum * double(full) / step;
    others += t;
    m[i] = int64_t(std::floor(t));
    given += m[i];
    rest.push_back({t - double(m[i]), i});
  }
  const int64_t units = std::llround(others);
  std::stable_sort(rest.begin(), rest.end(), [](auto& a, auto& b) { return a.first > b.first; });
  for (size_t k = 0; given < units && k < rest.size(); ++k, ++given) ++m[rest[k].second];
  int64_t taken = 0;
  for (size_t i = 1; i < list.size(); ++i) taken += (codes[i] = uint16_t(double(m[i]) * step));
  codes[0] = uint16_t(full - taken);
  return codes;
}

SkinSets skin_sets(const BodyModel& b, bool lossless, float min_weight, int weight_bits) {
  const int V = b.num_verts;
  std::vector<std::vector<std::pair<float, int>>> infl(static_cast<size_t>(V));
  SkinSets s;
  for (int v = 0; v < V; ++v) {
    auto& list = infl[size_t(v)];
    const float* w = &b.weights[size_t(v) * kNumJoints];
    int nonzero = 0;
    for (int j = 0; j < kNumJoints; ++j) nonzero += w[j] != 0.0f;
    s.max_influences = std::max(s.max_influences, nonzero);
    for (int j = 0; j < kNumJoints; ++j) {
      if (w[j] != 0.0f && (lossless || w[j] >= min_weight)) list.push_back({w[j], j});
    }
    if (list.empty()) {  // every weight tiny: keep the largest
      int best = int(std::max_element(w, w + kNumJoints) - w);
      list.push_back({w[best], best});
    }
    // Largest first, so JOINTS_0/WEIGHTS_0 alone is the best 4-influence approximation.
    std::stable_sort(list.begin(), list.end(), [](auto& a, auto& c) { return a.first > c.first; });
  }
  size_t most = 1;
  for (auto& l : infl) most = std::max(most, l.size());
  s.sets = int((most + 3) / 4);
  s.joints.assign(size_t(s.sets) * V * 4, 0);
  if (lossless) s.weights.assign(size_t(s.sets) * V * 4, 0.0f);
  else s.codes.assign(size_t(s.sets) * V * 4, 0);
  for (int v = 0; v < V; ++v) {
    const auto& list = infl[size_t(v)];
    const std::vector<uint16_t> codes = lossless ? std::vector<uint16_t>() : weight_codes(list, weight_bits);
    for (size_t i = 0; i < list.size(); ++i) {
      const size_t at = ((i / 4) * V + size_t(v)) * 4 + i % 4;
      // A weight whose code rounds to zero names joint 0, as glTF asks of unused slots
      // (the validator warns of a zero weight on a non-zero joint).
      s.joints[at] = lossless || codes[i] != 0 ? uint8_t(list[i].second) : 0;
      if (lossless) s.weights[at] = list[i].first;
      else s.codes[at] = codes[i];
    }
  }
  return s;
}

template <class T>
std::vector<T> gather(const std::vector<T>& per_body_vertex, const std::vector<int32_t>& source, int comps) {
  std::vector<T> out(source.size() * size_t(comps));
  for (size_t g = 0; g < source.size(); ++g)
    for (int k = 0; k < comps; ++k) out[g * comps + k] = per_body_vertex[size_t(source[g]) * comps + k];
  return out;
}

}  // namespace

int default_texture_quality(int side) { return side <= 512 ? 90 : 75; }

std::vector<float> baked_rest_vertices(const Avatar& a) {
  std::vector<float> out = shaped_rest_vertices(a);
  const std::vector<float>& d = a.body.rest_offsets;
  if (!d.empty()) {
    if (d.size() != out.size()) fail("avatar", "rest_offsets: " + std::to_string(d.size()) + " values for " + std::to_string(out.size() / 3) + " vertices");
    for (size_t i = 0; i < out.size(); ++i) out[i] += d[i];  // the float sum LBS makes (body/lbs.cpp)
  }
  return out;
}

std::vector<float> shaped_rest_vertices(const Avatar& a) {
  const BodyModel& b = a.body;
  const size_t V = size_t(b.num_verts);
  std::vector<float> out(b.v_template);
  const int cols = b.num_shape + b.num_expr;
  if (!has_shape_blend(b)) return out;  // already baked (e.g. an unpacked avatar)
  if (int(a.betas.size()) > b.num_shape) {
    fail("avatar", "betas: " + std::to_string(a.betas.size()) + " values but the body model has " +
                       std::to_string(b.num_shape) + " shape directions");
  }
  if (int(a.expression.size()) > b.num_expr) {
    fail("avatar", "expression: " + std::to_string(a.expression.size()) + " values but the body model has " +
                       std::to_string(b.num_expr) + " expression directions");
  }
  for (size_t i = 0; i < V * 3; ++i) {
    const float* d = &b.shapedirs[i * size_t(cols)];
    double acc = b.v_template[i];
    for (size_t k = 0; k < a.betas.size(); ++k) acc += double(d[k]) * a.betas[k];
    for (size_t k = 0; k < a.expression.size(); ++k) acc += double(d[b.num_shape + k]) * a.expression[k];
    out[i] = float(acc);
  }
  return out;
}

namespace {

// The .glb under construction: the glTF JSON parts, the binary chunk they point into, the
// HAHA_gaussian_avatar object and the bytes per part. The part writers below append to it
// in file order (buffer views and accessors are numbered as they are added).
struct GlbDoc {
  glb::BinWriter bin;
  Json accessors = Json::array(), nodes = Json::array(), meshes = Json::array(), scene_nodes = Json::array();
  Json skins, materials, samplers, images, texture;
  Json used = {"KHR_draco_mesh_compression", "KHR_materials_unlit", kAvatarExtension};
  Json required = {"KHR_draco_mesh_compression"};
  Json ext;  // HAHA_gaussian_avatar
  PackedSizes sz;
  // The face the Gaussians of each body face name (gaussians.faceOrder: the canonical
  // order, or the file's in lossless packs) and which of its corners is the body face's
  // corner 0.
  std::vector<int32_t> file_face;
  std::vector<uint8_t> file_corner;
  int add_accessor(Json acc) {
    accessors.push_back(std::move(acc));
    return int(accessors.size()) - 1;
  }
};

// The subject's rest shape (betas baked in) and its joints.
struct RestBody {
  std::vector<float> verts;   // (V, 3)
  std::vector<double> joints;  // (55, 3)
};

RestBody rest_body(const Avatar& a) {
  const BodyModel& b = a.body;
  const int V = b.num_verts;
  RestBody r;
  r.verts = baked_rest_vertices(a);
  r.joints.assign(kNumJoints * 3, 0.0);
  if (b.j_regressor.empty()) {  // an unpacked avatar: its rest joints are stored
    for (size_t i = 0; i < r.joints.size(); ++i) r.joints[i] = b.joints_rest[i];
    return r;
  }
  // The joints of the bare body: a rest displacement (clothes) does not move the skeleton.
  const std::vector<float> bare = b.rest_offsets.empty() ? std::vector<float>() : shaped_rest_vertices(a);
  const std::vector<float>& src = bare.empty() ? r.verts : bare;
  for (int j = 0; j < kNumJoints; ++j)
    for (int v = 0; v < V; ++v) {
      const double w = b.j_regressor[size_t(j) * V + v];
      if (w != 0.0)
        for (int k = 0; k < 3; ++k) r.joints[size_t(j) * 3 + k] += w * src[size_t(v) * 3 + k];
    }
  return r;
}

// Whether a decoded (edgebreaker) mesh gives the reader back the body: every body vertex
// through _BODY_VERTEX, and the body's faces as the same canonical face list (the order the
// Gaussians name). False: the caller keeps the face order instead.
bool keeps_body_faces(const dracoio::Decoded& dec, int body_vertex_id, const BodyModel& b, const MeshPart& part) {
  const int F = part.num_faces();
  if (dec.num_faces() != F) return false;
  const std::vector<int64_t> bv = dec.ints(body_vertex_id, 1, "_BODY_VERTEX");
  std::vector<char> seen(size_t(part.v1 - part.v0), 0);
  for (int64_t v : bv) {
    if (v < part.v0 || v >= part.v1) return false;
    seen[size_t(v - part.v0)] = 1;
  }
  if (std::count(seen.begin(), seen.end(), 0) != 0) return false;
  std::vector<int32_t> file_faces = dec.faces();
  for (int32_t& c : file_faces) c = int32_t(bv[size_t(c)]);
  const std::vector<int32_t> part_faces(b.faces.begin() + long(part.f0) * 3, b.faces.begin() + long(part.f1) * 3);
  auto canonical_list = [F](const std::vector<int32_t>& faces) {
    const CanonicalFaces c = canonical_faces(faces.data(), F);
    std::vector<std::array<int32_t, 3>> out;
    for (int32_t f : c.order) {
      const size_t r = c.rotation[size_t(f)], o = size_t(f) * 3;
      out.push_back({faces[o + r], faces[o + (r + 1) % 3], faces[o + (r + 2) % 3]});
    }
    return out;
  };
  return canonical_list(file_faces) == canonical_list(part_faces);
}

// One primitive's per-glTF-vertex arrays (split at UV seams), what both storages write.
struct BodyArrays {
  MeshPart part;
  SplitMesh split;
  std::vector<float> pos, nrm, uv, uv_src;           // (Vg, 3), (Vg, 3) or empty, (Vg, 2), (Vg, 2)
  int skin_sets = 0;
  std::vector<std::vector<uint8_t>> joints;           // per set (Vg, 4)
  std::vector<std::vector<float>> weights;            // per set (Vg, 4), lossless
  std::vector<std::vector<uint16_t>> codes;           // per set (Vg, 4), lossy
  std::vector<uint16_t> source16;                     // _BODY_VERTEX when V <= 65536
  std::vector<float> source_float;                    // _BODY_VERTEX otherwise
  // COLOR_0 (Vg, 4) of an avatar with a mesh coverage: white, alpha = the coverage of the
  // glTF vertex's body vertex; 8-bit codes, or float32 in lossless packs. Empty: none.
  std::vector<uint8_t> color8;
  std::vector<float> color32;
};

// COLOR_0 from the per-body-vertex coverage. The 8-bit alpha keeps every vertex on its side
// of the cut: c >= 0.5 rounds to >= 128/255, c < 0.5 to <= 127/255.
void coverage_colors(const std::vector<float>& coverage, const std::vector<int32_t>& source, bool lossless, BodyArrays& r) {
  if (coverage.empty()) return;
  const size_t Vg = source.size();
  if (lossless) r.color32.assign(Vg * 4, 1.0f);
  else r.color8.assign(Vg * 4, 255);
  for (size_t g = 0; g < Vg; ++g) {
    const float c = coverage[size_t(source[g])];
    if (lossless) r.color32[g * 4 + 3] = c;
    else r.color8[g * 4 + 3] = uint8_t(std::lround(255.0 * double(c)));
  }
}

// What every primitive gathers from: the whole mesh's rest normals and skin.
struct WholeMesh {
  std::vector<float> normals;  // (V, 3) or empty
  SkinSets skin;
};

BodyArrays body_arrays(const Avatar& a, const RestBody& rest, const WholeMesh& whole, const MeshPart& part, const PackOptions& opt) {
  const BodyModel& b = a.body;
  const int V = b.num_verts;
  BodyArrays r;
  r.part = part;
  r.split = split_at_seams(b, part);
  const int Vg = int(r.split.source.size());
  r.pos = gather(rest.verts, r.split.source, 3);
  if (opt.normals) r.nrm = gather(whole.normals, r.split.source, 3);
  r.uv.assign(size_t(Vg) * 2, 0.0f);
  r.uv_src.assign(size_t(Vg) * 2, 0.0f);
  for (int g = 0; g < Vg; ++g) {
    const int32_t t = r.split.uv_of[size_t(g)];
    if (t < 0) continue;
    r.uv_src[size_t(g) * 2] = b.vt[size_t(t) * 2];
    r.uv_src[size_t(g) * 2 + 1] = b.vt[size_t(t) * 2 + 1];
    r.uv[size_t(g) * 2] = r.uv_src[size_t(g) * 2];
    r.uv[size_t(g) * 2 + 1] = 1.0f - r.uv_src[size_t(g) * 2 + 1];  // glTF UV origin: top-left
  }
  const SkinSets& skin = whole.skin;
  r.skin_sets = skin.sets;
  const size_t set_size = size_t(V) * 4;
  for (int s = 0; s < skin.sets; ++s) {
    const auto first = [&](auto& v) { return v.begin() + long(size_t(s) * set_size); };
    r.joints.push_back(gather(std::vector<uint8_t>(first(skin.joints), first(skin.joints) + long(set_size)), r.split.source, 4));
    if (opt.lossless) {
      r.weights.push_back(gather(std::vector<float>(first(skin.weights), first(skin.weights) + long(set_size)), r.split.source, 4));
    } else {
      r.codes.push_back(gather(std::vector<uint16_t>(first(skin.codes), first(skin.codes) + long(set_size)), r.split.source, 4));
    }
  }
  coverage_colors(a.mesh_coverage, r.split.source, opt.lossless, r);
  if (V <= 65536) r.source16.assign(r.split.source.begin(), r.split.source.end());
  if (V > (1 << 24)) fail("avatar", "more than 2^24 body vertices");
  if (V > 65536) r.source_float.assign(r.split.source.begin(), r.split.source.end());
  return r;
}

// Bounds of the POSITION accessor.
Json position_bounds(const std::vector<float>& p, Json acc) {
  std::vector<float> mn(3, INFINITY), mx(3, -INFINITY);
  for (size_t g = 0; g < p.size() / 3; ++g)
    for (size_t k = 0; k < 3; ++k) {
      mn[k] = std::min(mn[k], p[g * 3 + k]);
      mx[k] = std::max(mx[k], p[g * 3 + k]);
    }
  acc["min"] = float_array(mn.data(), 3);
  acc["max"] = float_array(mx.data(), 3);
  return acc;
}

// One primitive as KHR_draco_mesh_compression (edgebreaker, or sequential to keep the
// body's face order; lossless: sequential, float32), a stream of its own. Returns the
// primitive; `record` gets what the extension says of the stream (body.draco).
Json add_draco_body_mesh(GlbDoc& d, const Avatar& a, const BodyArrays& r, const PackOptions& opt, Json& record) {
  const BodyModel& b = a.body;
  const bool lossless = opt.lossless;
  const MeshBits mb = lossless ? MeshBits{0, 0, 0, 0} : opt.mesh_bits;
  const int F = r.part.num_faces(), Vg = int(r.split.source.size());
  using dracoio::AttrIn;
  using dracoio::Kind;
  using dracoio::Type;
  std::vector<AttrIn> mattrs;
  mattrs.push_back({"POSITION", Kind::position, Type::f32, 3, r.pos.data(), mb.position});
  if (opt.normals) mattrs.push_back({"NORMAL", Kind::normal, Type::f32, 3, r.nrm.data(), mb.normal});
  mattrs.push_back({"TEXCOORD_0", Kind::texcoord, Type::f32, 2, r.uv.data(), mb.texcoord});
  for (int s = 0; s < r.skin_sets; ++s) {
    mattrs.push_back({"JOINTS_" + std::to_string(s), Kind::generic, Type::u8, 4, r.joints[size_t(s)].data(), 0});
    if (lossless) mattrs.push_back({"WEIGHTS_" + std::to_string(s), Kind::generic, Type::f32, 4, r.weights[size_t(s)].data(), 0});
    else mattrs.push_back({"WEIGHTS_" + std::to_string(s), Kind::generic, Type::u16, 4, r.codes[size_t(s)].data(), 0, true, true});
  }
  const bool coverage = !r.color8.empty() || !r.color32.empty();
  if (!r.color8.empty()) mattrs.push_back({"COLOR_0", Kind::color, Type::u8, 4, r.color8.data(), 0, true, true});
  if (!r.color32.empty()) mattrs.push_back({"COLOR_0", Kind::color, Type::f32, 4, r.color32.data(), 0});
  const bool wide_index = r.source16.empty();
  mattrs.push_back({"_BODY_VERTEX", Kind::generic, wide_index ? Type::f32 : Type::u16, 1,
                    wide_index ? static_cast<const void*>(r.source_float.data()) : static_cast<const void*>(r.source16.data()), 0});
  const size_t first_private = mattrs.size();
  if (lossless) mattrs.push_back({"TEXCOORD_SOURCE", Kind::generic, Type::f32, 2, r.uv_src.data(), 0});
  const int body_vertex_attr = int(first_private) - 1;
  dracoio::Method method = lossless || opt.keep_face_order ? dracoio::Method::sequential : dracoio::Method::edgebreaker;
  dracoio::Encoded mesh_enc = dracoio::encode(Vg, mattrs, r.split.faces.data(), F, method);
  // Decode our own stream: it gives exact accessor bounds, checks that every body face
  // comes back, and guards the face order (a Draco build that reordered sequential faces
  // would fail here, not later).
  std::unique_ptr<dracoio::Decoded> dec =
      std::make_unique<dracoio::Decoded>(mesh_enc.bytes.data(), mesh_enc.bytes.size(), true, "pack", "mesh");
  if (method == dracoio::Method::edgebreaker && !keeps_body_faces(*dec, mesh_enc.unique_ids[size_t(body_vertex_attr)], b, r.part)) {
    method = dracoio::Method::sequential;  // an edgebreaker part that cannot map back: keep the face order
    mesh_enc = dracoio::encode(Vg, mattrs, r.split.faces.data(), F, method);
    dec = std::make_unique<dracoio::Decoded>(mesh_enc.bytes.data(), mesh_enc.bytes.size(), true, "pack", "mesh");
  }
  if (method == dracoio::Method::sequential &&
      (dec->num_faces() != F || dec->num_points() != Vg || dec->faces() != r.split.faces)) {
    fail("pack", "Draco changed the mesh's face or vertex order; refusing to write a file whose Gaussians would bind to the wrong faces");
  }
  d.sz.edgebreaker = d.sz.edgebreaker || method == dracoio::Method::edgebreaker;
  d.sz.draco_mesh = true;
  const int Vf = dec->num_points();  // edgebreaker may drop unreferenced points
  d.sz.num_vertices += Vf;
  const int mesh_view = d.bin.add_view(mesh_enc.bytes.data(), mesh_enc.bytes.size());
  d.sz.mesh += mesh_enc.bytes.size();

  Json prim_attrs, draco_attrs;
  const int idx_acc = d.add_accessor({{"componentType", Vf > 65535 ? kUInt : kUShort}, {"count", size_t(F) * 3}, {"type", "SCALAR"}});
  prim_attrs["POSITION"] = d.add_accessor(position_bounds(dec->floats(mesh_enc.unique_ids[0], 3, "POSITION"),
                                                          {{"componentType", kFloat}, {"count", Vf}, {"type", "VEC3"}}));
  if (opt.normals) prim_attrs["NORMAL"] = d.add_accessor({{"componentType", kFloat}, {"count", Vf}, {"type", "VEC3"}});
  prim_attrs["TEXCOORD_0"] = d.add_accessor({{"componentType", kFloat}, {"count", Vf}, {"type", "VEC2"}});
  for (int s = 0; s < r.skin_sets; ++s) {
    prim_attrs["JOINTS_" + std::to_string(s)] = d.add_accessor({{"componentType", kUByte}, {"count", Vf}, {"type", "VEC4"}});
    Json w = {{"componentType", lossless ? kFloat : kUShort}, {"count", Vf}, {"type", "VEC4"}};
    if (!lossless) w["normalized"] = true;
    prim_attrs["WEIGHTS_" + std::to_string(s)] = d.add_accessor(w);
  }
  if (coverage) {
    Json c = {{"componentType", lossless ? kFloat : kUByte}, {"count", Vf}, {"type", "VEC4"}};
    if (!lossless) c["normalized"] = true;
    prim_attrs["COLOR_0"] = d.add_accessor(c);
  }
  prim_attrs["_BODY_VERTEX"] = d.add_accessor({{"componentType", wide_index ? kFloat : kUShort}, {"count", Vf}, {"type", "SCALAR"}});
  for (size_t i = 0; i < first_private; ++i) draco_attrs[mattrs[i].name] = mesh_enc.unique_ids[i];

  Json mesh_private = Json::object();
  for (size_t i = first_private; i < mattrs.size(); ++i) mesh_private[mattrs[i].name] = mesh_enc.unique_ids[i];
  Json m_bits = {{"POSITION", mb.position}, {"TEXCOORD_0", mb.texcoord}, {"WEIGHTS", mb.weight}};
  if (opt.normals) m_bits["NORMAL"] = mb.normal;
  record = {{"bufferView", mesh_view}, {"crc32", d.bin.view_crc(mesh_view)}, {"attributes", mesh_private},
                            {"quantizationBits", m_bits}, {"method", method == dracoio::Method::edgebreaker ? "edgebreaker" : "sequential"}};
  return {{"attributes", prim_attrs},
          {"indices", idx_acc},
          {"mode", 4},
          {"material", 0},
          {"extensions", {{"KHR_draco_mesh_compression", {{"bufferView", mesh_view}, {"attributes", draco_attrs}}}}}};
}

// One primitive as plain accessors (no required extension; format/spec.md section 2).
Json add_plain_body_mesh(GlbDoc& d, const BodyArrays& r, const PackOptions& opt) {
  const int Vg = int(r.split.source.size()), F = int(r.split.faces.size() / 3);
  auto add = [&](const void* data, size_t bytes, int target, Json acc) {
    acc["bufferView"] = d.bin.add_view(data, bytes, 4, target);
    d.sz.mesh += bytes;
    return d.add_accessor(std::move(acc));
  };
  Json attrs;
  attrs["POSITION"] = add(r.pos.data(), r.pos.size() * 4, kArrayBuffer,
                          position_bounds(r.pos, {{"componentType", kFloat}, {"count", Vg}, {"type", "VEC3"}}));
  if (opt.normals) attrs["NORMAL"] = add(r.nrm.data(), r.nrm.size() * 4, kArrayBuffer, {{"componentType", kFloat}, {"count", Vg}, {"type", "VEC3"}});
  // Float UVs: Godot 3 ignores `normalized` on integer UVs (measured: one texel everywhere).
  attrs["TEXCOORD_0"] = add(r.uv.data(), r.uv.size() * 4, kArrayBuffer, {{"componentType", kFloat}, {"count", Vg}, {"type", "VEC2"}});
  for (int s = 0; s < r.skin_sets; ++s) {
    const std::string n = std::to_string(s);
    attrs["JOINTS_" + n] = add(r.joints[size_t(s)].data(), r.joints[size_t(s)].size(), kArrayBuffer,
                               {{"componentType", kUByte}, {"count", Vg}, {"type", "VEC4"}});
    attrs["WEIGHTS_" + n] = add(r.codes[size_t(s)].data(), r.codes[size_t(s)].size() * 2, kArrayBuffer,
                                {{"componentType", kUShort}, {"normalized", true}, {"count", Vg}, {"type", "VEC4"}});
  }
  if (!r.color8.empty()) {
    attrs["COLOR_0"] = add(r.color8.data(), r.color8.size(), kArrayBuffer,
                           {{"componentType", kUByte}, {"normalized", true}, {"count", Vg}, {"type", "VEC4"}});
  }
  // Unsigned shorts padded to glTF's 4-byte vertex alignment (byteStride 4), so a tool that
  // re-encodes the mesh keeps them integers (a float map would be quantized); float (exact
  // integers) for more vertices: glTF allows no unsigned int vertex attribute.
  if (!r.source16.empty()) {
    std::vector<uint16_t> padded(size_t(Vg) * 2, 0);
    for (int g = 0; g < Vg; ++g) padded[size_t(g) * 2] = r.source16[size_t(g)];
    const int view = d.bin.add_view(padded.data(), padded.size() * 2, 4, kArrayBuffer, 4);
    d.sz.mesh += padded.size() * 2;
    attrs["_BODY_VERTEX"] = d.add_accessor({{"bufferView", view}, {"componentType", kUShort}, {"count", Vg}, {"type", "SCALAR"}});
  } else {
    attrs["_BODY_VERTEX"] = add(r.source_float.data(), r.source_float.size() * 4, kArrayBuffer,
                                {{"componentType", kFloat}, {"count", Vg}, {"type", "SCALAR"}});
  }
  int indices;
  if (Vg <= 65535) {
    const std::vector<uint16_t> idx(r.split.faces.begin(), r.split.faces.end());
    indices = add(idx.data(), idx.size() * 2, kElementArrayBuffer, {{"componentType", kUShort}, {"count", size_t(F) * 3}, {"type", "SCALAR"}});
  } else {
    indices = add(r.split.faces.data(), r.split.faces.size() * 4, kElementArrayBuffer, {{"componentType", kUInt}, {"count", size_t(F) * 3}, {"type", "SCALAR"}});
  }
  d.sz.num_vertices += Vg;
  return {{"attributes", attrs}, {"indices", indices}, {"mode", 4}, {"material", 0}};
}

// The face the Gaussians of each body face name (d.file_face) and which of its corners is
// the body face's corner 0 (d.file_corner): the file's order in lossless packs, else the
// canonical order.
void bind_face_order(GlbDoc& d, const BodyModel& b, bool lossless) {
  const int F = b.num_faces;
  d.file_face.resize(size_t(F));
  if (lossless) {
    for (int f = 0; f < F; ++f) d.file_face[size_t(f)] = f;
    d.file_corner.assign(size_t(F), 0);
    return;
  }
  const CanonicalFaces c = canonical_faces(b.faces.data(), F);
  d.file_corner.resize(size_t(F));
  for (int k = 0; k < F; ++k) d.file_face[size_t(c.order[size_t(k)])] = k;
  // Body corner 0 sits at canonical corner (3 - rotation) mod 3.
  for (int f = 0; f < F; ++f) d.file_corner[size_t(f)] = uint8_t((3 - c.rotation[size_t(f)]) % 3);
}

// The skinned, textured body mesh (mesh 0): the body as primitive 0 and a garment, when
// there is one, as primitive 1 (the same node, so the same skin). The Gaussians' face
// indices stay the whole mesh's (primitive 0's triangles, then primitive 1's), in the face
// order they bind to: canonical (lossy packs: any tool may reorder the mesh) or the
// file's (lossless packs, whose sequential Draco streams keep the body's order).
void add_body_mesh(GlbDoc& d, const Avatar& a, const RestBody& rest, const PackOptions& opt) {
  const BodyModel& b = a.body;
  WholeMesh whole;
  if (opt.normals) whole.normals = vertex_normals(rest.verts, b);
  whole.skin = skin_sets(b, opt.lossless, opt.min_skin_weight, opt.mesh_bits.weight);
  d.sz.skin_sets = whole.skin.sets;
  d.sz.max_influences = whole.skin.max_influences;
  const bool draco = opt.mesh_compression == MeshCompression::draco;
  Json primitives = Json::array(), records = Json::array();
  for (const MeshPart& part : mesh_parts(b)) {
    const BodyArrays r = body_arrays(a, rest, whole, part, opt);
    Json record;
    primitives.push_back(draco ? add_draco_body_mesh(d, a, r, opt, record) : add_plain_body_mesh(d, r, opt));
    records.push_back(record);
  }
  if (!draco) {
    d.used.erase(std::find(d.used.begin(), d.used.end(), "KHR_draco_mesh_compression"));
    d.required.erase(std::find(d.required.begin(), d.required.end(), "KHR_draco_mesh_compression"));
  }
  d.meshes.push_back({{"name", "body"}, {"primitives", primitives}});
  bind_face_order(d, b, opt.lossless);
  Json& body = d.ext["body"];
  if (draco) body["draco"] = records[0];
  body["mesh"] = 0;
  body["vertexCount"] = b.num_verts;
  body["faceCount"] = b.num_faces;
  body["skinSets"] = whole.skin.sets;
  body["shapeBaked"] = true;
  // Whether the trainer's LBS applied pose correctives (a body with posedirs always does),
  // and which topology supplies them when they are not embedded.
  body["trainedWithPoseCorrectives"] = !b.posedirs.empty();
  body["topologyCrc32"] = glb::crc32(reinterpret_cast<const uint8_t*>(b.faces.data()), b.faces.size() * 4);
  if (b.has_garment()) {  // the garment's primitive, and the Gaussians it carries
    const auto& gf = a.gaussians.face;
    const long carried = std::count_if(gf.begin(), gf.end(), [&](int32_t f) { return f >= b.garment_first_face; });
    body["garment"] = {{"primitive", 1}, {"firstVertex", b.garment_first_vert}, {"firstFace", b.garment_first_face},
                       {"chart", b.garment_chart}, {"gaussians", carried}};
    if (draco) body["garment"]["draco"] = records[1];
  }
}

// The skeleton: joint nodes (identity rest rotation, translation = offset to the parent),
// the body node with its skin, inverse bind matrices, and the sparse joint regressor
// (joint, vertex, weight) so a loader regresses the same joints.
void add_skeleton(GlbDoc& d, const BodyModel& b, const RestBody& rest, bool with_regressor) {
  const int V = b.num_verts;
  const std::vector<double>& joints = rest.joints;
  std::vector<Json> children(kNumJoints, Json::array());
  for (int j = 1; j < kNumJoints; ++j) children[size_t(b.parents[size_t(j)])].push_back(j);
  for (int j = 0; j < kNumJoints; ++j) {
    const int p = b.parents[size_t(j)];
    float t[3];
    for (int k = 0; k < 3; ++k) t[k] = float(joints[size_t(j) * 3 + k] - (p >= 0 ? joints[size_t(p) * 3 + k] : 0.0));
    Json node = {{"name", kSmplxJointNames[j]}, {"translation", float_array(t, 3)}};
    if (!children[size_t(j)].empty()) node["children"] = children[size_t(j)];
    d.nodes.push_back(node);
  }
  const int mesh_node = int(d.nodes.size());
  d.nodes.push_back({{"name", "body"}, {"mesh", 0}, {"skin", 0}});
  d.scene_nodes = {0, mesh_node};
  std::vector<float> ibm(size_t(kNumJoints) * 16, 0.0f);
  for (int j = 0; j < kNumJoints; ++j) {
    float* m = &ibm[size_t(j) * 16];  // column-major: translation in elements 12..14
    m[0] = m[5] = m[10] = m[15] = 1.0f;
    for (int k = 0; k < 3; ++k) m[12 + k] = float(-joints[size_t(j) * 3 + k]);
  }
  const int ibm_view = d.bin.add_view(ibm.data(), ibm.size() * sizeof(float));
  const int ibm_acc = d.add_accessor({{"bufferView", ibm_view}, {"componentType", kFloat}, {"count", kNumJoints}, {"type", "MAT4"}});
  Json joint_list = Json::array();
  for (int j = 0; j < kNumJoints; ++j) joint_list.push_back(j);
  d.skins = Json::array({{{"name", "smplx"}, {"inverseBindMatrices", ibm_acc}, {"joints", joint_list}, {"skeleton", 0}}});
  d.sz.skeleton += ibm.size() * sizeof(float);
  d.ext["body"]["node"] = mesh_node;
  d.ext["body"]["skin"] = 0;
  // The shape is baked, so the rest joints never change: loaders take them from the
  // inverse bind matrices. The regressor (17 KB for SMPL-X) only travels in lossless packs,
  // and never with a rest displacement: regressed from the stored (displaced) positions it
  // would move the joints.
  if (!with_regressor || b.j_regressor.empty() || !b.rest_offsets.empty()) return;

  std::vector<int32_t> jr_joint, jr_vert;
  std::vector<float> jr_w;
  for (int j = 0; j < kNumJoints; ++j)
    for (int v = 0; v < V; ++v) {
      const float w = b.j_regressor[size_t(j) * V + v];
      if (w != 0.0f) {
        jr_joint.push_back(j);
        jr_vert.push_back(v);
        jr_w.push_back(w);
      }
    }
  std::vector<uint8_t> jr_bytes(jr_w.size() * 12);
  std::memcpy(jr_bytes.data(), jr_joint.data(), jr_w.size() * 4);
  std::memcpy(jr_bytes.data() + jr_w.size() * 4, jr_vert.data(), jr_w.size() * 4);
  std::memcpy(jr_bytes.data() + jr_w.size() * 8, jr_w.data(), jr_w.size() * 4);
  const int jr_view = d.bin.add_view(jr_bytes.data(), jr_bytes.size());
  d.sz.skeleton += jr_bytes.size();
  d.ext["body"]["jointRegressor"] = {{"bufferView", jr_view}, {"count", jr_w.size()}, {"crc32", d.bin.view_crc(jr_view)}};
}

// The texture image (png / jpg / webp) and the unlit material that samples it.
void add_texture(GlbDoc& d, const Avatar& a, const PackOptions& opt) {
  Texture tex = a.texture;
  if (opt.texture_size > 0) tex = resize_texture(tex, opt.texture_size, opt.texture_size);
  const int quality = opt.texture_quality > 0 ? opt.texture_quality : default_texture_quality(tex.width);
  const std::vector<uint8_t> img = encode_texture(tex, opt.texture_codec, quality);
  const int img_view = d.bin.add_view(img.data(), img.size());
  d.sz.texture = img.size();
  d.images = Json::array({{{"bufferView", img_view}, {"mimeType", texture_mime(opt.texture_codec)}, {"name", "texture"}}});
  d.texture = {{"sampler", 0}};
  if (opt.texture_codec == TextureCodec::webp) {
    d.texture["extensions"] = {{"EXT_texture_webp", {{"source", 0}}}};
    d.used.push_back("EXT_texture_webp");
    d.required.push_back("EXT_texture_webp");
  } else {
    d.texture["source"] = 0;
  }
  // Linear filtering, clamp to edge: what the trainer's bilinear sampler does.
  d.samplers = Json::array({{{"magFilter", 9729}, {"minFilter", 9729}, {"wrapS", 33071}, {"wrapT", 33071}}});
  d.materials = Json::array({{{"name", "avatar"},
                              {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
                              {"extensions", {{"KHR_materials_unlit", Json::object()}}}}});
  // A mesh coverage is COLOR_0's alpha, which glTF multiplies into the base colour: MASK
  // cuts the mesh in every viewer where haha's renderer cuts it.
  if (!a.mesh_coverage.empty()) {
    d.materials[0]["alphaMode"] = "MASK";
    d.materials[0]["alphaCutoff"] = glb::json_float(kCoverageCutoff);
  }
  d.ext["texture"] = {{"image", 0}, {"crc32", d.bin.view_crc(img_view)}, {"width", tex.width}, {"height", tex.height}};
}

// Lossless packs also carry the trained float32 texture, after the Gaussians.
void add_exact_texture(GlbDoc& d, const Avatar& a) {
  const int ex_view = d.bin.add_view(a.texture.rgb.data(), a.texture.rgb.size() * sizeof(float));
  d.ext["texture"]["exact"] = {{"bufferView", ex_view}, {"width", a.texture.width}, {"height", a.texture.height},
                               {"crc32", d.bin.view_crc(ex_view)}};
  d.sz.texture_exact = a.texture.rgb.size() * sizeof(float);
}

// One Draco point cloud of the Gaussians listed in `order` (in that order), with
// per-attribute quantization; the attribute ids and bits go to `ids` / `bits`.
dracoio::Encoded encode_gaussians(const GlbDoc& d, const BoundGaussians& G, const std::vector<int32_t>& order, bool lossless,
                                  const GaussianBits& gb, Json& ids, Json& bits) {
  const int N = int(order.size());
  auto permuted = [&](const auto& v, int comps) {
    std::remove_cvref_t<decltype(v)> out(size_t(N) * size_t(comps));
    for (int i = 0; i < N; ++i)
      for (int k = 0; k < comps; ++k) out[size_t(i) * comps + k] = v[size_t(order[size_t(i)]) * comps + k];
    return out;
  };
  std::vector<int32_t> face(static_cast<size_t>(N));
  std::vector<uint8_t> corner(static_cast<size_t>(N));
  for (int i = 0; i < N; ++i) {
    face[size_t(i)] = d.file_face[size_t(G.face[size_t(order[size_t(i)])])];
    corner[size_t(i)] = d.file_corner[size_t(G.face[size_t(order[size_t(i)])])];
  }
  const std::vector<float> offset = permuted(G.offset, 3), color = permuted(G.color, 3), opacity = permuted(G.opacity, 1);
  std::vector<float> rot = permuted(G.rotation, 4), scl = permuted(G.scale, 3);
  std::vector<uint8_t> largest;
  if (!lossless) {
    // "Smallest three": drop the largest |component| (>= 1/2 for a unit quaternion), made
    // positive via q -> -q; the other three lie in [-1/sqrt 2, 1/sqrt 2], so the same bits
    // give sqrt(2) finer steps than four components in [-1, 1], and a quarter fewer values.
    std::vector<float> rot3(size_t(N) * 3);
    largest.resize(size_t(N));
    for (int i = 0; i < N; ++i) {
      const float* q = &rot[size_t(i) * 4];
      const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
      int m = 0;
      for (int k = 1; k < 4; ++k)
        if (std::fabs(q[k]) > std::fabs(q[m])) m = k;
      const double sgn = q[m] < 0 ? -1.0 : 1.0;
      largest[size_t(i)] = uint8_t(m);
      for (int k = 0, o = 0; k < 4; ++k)
        if (k != m) rot3[size_t(i) * 3 + o++] = float(sgn * q[k] / n);
    }
    rot = std::move(rot3);
    for (float& x : scl) x = std::log(x);  // scales span decades: quantize them in log space
  }
  using dracoio::AttrIn;
  using dracoio::Kind;
  using dracoio::Type;
  // Delta prediction only where consecutive Gaussians are related (face indices, offsets
  // and colours along the face order); measured smaller that way, the others without.
  std::vector<AttrIn> gattrs = {
      {"FACE", Kind::generic, Type::i32, 1, face.data(), 0, true},
      {"OFFSET", Kind::generic, Type::f32, 3, offset.data(), gb.offset, true},
      {"ROTATION", Kind::generic, Type::f32, lossless ? 4 : 3, rot.data(), gb.rotation, false},
      {"SCALE", Kind::generic, Type::f32, 3, scl.data(), gb.scale, false},
      {"COLOR", Kind::generic, Type::f32, 3, color.data(), gb.color, true},
      {"OPACITY", Kind::generic, Type::f32, 1, opacity.data(), gb.opacity, false}};
  if (!lossless) gattrs.push_back({"ROTATION_LARGEST", Kind::generic, Type::u8, 1, largest.data(), 0, false});
  // Which corner of its canonical face is the body face's corner 0 (face frames depend on it).
  if (!lossless) gattrs.push_back({"FACE_CORNER", Kind::generic, Type::u8, 1, corner.data(), 0, true});
  const dracoio::Encoded genc = dracoio::encode(N, gattrs, nullptr, 0);
  ids = Json::object();
  bits = Json::object();
  for (size_t i = 0; i < gattrs.size(); ++i) {
    ids[gattrs[i].name] = genc.unique_ids[i];
    if (gattrs[i].type == Type::f32) bits[gattrs[i].name] = gattrs[i].quant_bits;
  }
  return genc;
}

// The face-bound Gaussians: one point cloud, or (--lod) one per importance tier. Within a
// point cloud lossy packs sort the Gaussians by (file) face, stably: the face index then
// costs ~2 bits instead of ~8, and the render does not depend on the order. Lossless keeps
// the trainer's order.
void add_gaussians(GlbDoc& d, const Avatar& a, const PackOptions& opt) {
  const bool lossless = opt.lossless;
  const GaussianBits gb = lossless ? GaussianBits{0, 0, 0, 0, 0} : opt.gaussian_bits;
  const BoundGaussians& G = a.gaussians;
  const int N = G.size();
  Json& jg = d.ext["gaussians"];
  jg = {{"count", N},
        {"attributes", Json::object()},
        {"quantizationBits", Json::object()},
        {"scaleEncoding", lossless ? "linear" : "log"},
        {"rotationEncoding", lossless ? "wxyz" : "smallest3"},
        {"order", lossless ? "original" : "face"},
        {"faceOrder", lossless ? "file" : "canonical"}};
  if (N == 0) return;  // filtering removed every Gaussian: no point cloud (Draco has no empty one)
  auto face_sorted = [&](std::vector<int32_t> order) {
    if (!lossless)
      std::stable_sort(order.begin(), order.end(), [&](int32_t x, int32_t y) {
        return d.file_face[size_t(G.face[size_t(x)])] < d.file_face[size_t(G.face[size_t(y)])];
      });
    return order;
  };
  if (opt.lod_tiers <= 1) {
    std::vector<int32_t> order(static_cast<size_t>(N));
    for (int i = 0; i < N; ++i) order[size_t(i)] = i;
    const dracoio::Encoded genc = encode_gaussians(d, G, face_sorted(order), lossless, gb, jg["attributes"], jg["quantizationBits"]);
    const int g_view = d.bin.add_view(genc.bytes.data(), genc.bytes.size());
    d.sz.gaussians = genc.bytes.size();
    jg["bufferView"] = g_view;
    jg["crc32"] = d.bin.view_crc(g_view);
    return;
  }
  const LodPlan plan = plan_lod(a, opt.lod_tiers);
  Json tiers = Json::array();
  size_t first = 0;
  for (size_t t = 0; t < plan.counts.size(); ++t) {
    const std::vector<int32_t> part(plan.order.begin() + long(first), plan.order.begin() + long(first) + plan.counts[t]);
    first += size_t(plan.counts[t]);
    const dracoio::Encoded genc = encode_gaussians(d, G, face_sorted(part), lossless, gb, jg["attributes"], jg["quantizationBits"]);
    const int v = d.bin.add_view(genc.bytes.data(), genc.bytes.size());
    d.sz.gaussians += genc.bytes.size();
    Json tier = {{"count", plan.counts[t]}, {"bufferView", v}, {"crc32", d.bin.view_crc(v)}};
    if (std::isfinite(plan.psnr[t])) tier["psnr"] = std::round(plan.psnr[t] * 100.0) / 100.0;
    tiers.push_back(tier);
  }
  jg["tiers"] = tiers;
  d.sz.lod_tiers = int(plan.counts.size());
}

// The pose-corrective blend shapes: float32 (lossless) or int16 with one scale per pose
// feature (value = q * scale[feature]).
void add_pose_correctives(GlbDoc& d, const BodyModel& b, bool lossless) {
  const int V = b.num_verts;
  if (b.posedirs.size() != size_t(V) * 3 * kNumPoseFeatures) {
    fail("avatar", "--pose-correctives: the body model has no pose-corrective blend shapes (posedirs)");
  }
  Json pc;
  if (lossless) {
    const int v = d.bin.add_view(b.posedirs.data(), b.posedirs.size() * sizeof(float));
    pc = {{"bufferView", v}, {"componentType", "float32"}, {"crc32", d.bin.view_crc(v)}};
    d.sz.pose_correctives = d.bin.view_size(v);
  } else {
    std::vector<float> scale(kNumPoseFeatures, 0.0f);
    const size_t rows = size_t(V) * 3;
    for (size_t r = 0; r < rows; ++r)
      for (int f = 0; f < kNumPoseFeatures; ++f)
        scale[size_t(f)] = std::max(scale[size_t(f)], std::fabs(b.posedirs[r * kNumPoseFeatures + f]));
    for (float& s : scale) s = s > 0 ? s / 32767.0f : 1.0f;
    std::vector<int16_t> q(b.posedirs.size());
    for (size_t r = 0; r < rows; ++r)
      for (int f = 0; f < kNumPoseFeatures; ++f)
        q[r * kNumPoseFeatures + f] = int16_t(std::lround(b.posedirs[r * kNumPoseFeatures + f] / scale[size_t(f)]));
    const int v = d.bin.add_view(q.data(), q.size() * sizeof(int16_t));
    const int sv = d.bin.add_view(scale.data(), scale.size() * sizeof(float));
    pc = {{"bufferView", v}, {"componentType", "int16"}, {"crc32", d.bin.view_crc(v)},
          {"scaleBufferView", sv}, {"scaleCrc32", d.bin.view_crc(sv)}};
    d.sz.pose_correctives = d.bin.view_size(v) + d.bin.view_size(sv);
  }
  pc["encoding"] = "dense";
  d.ext["body"]["poseCorrectives"] = pc;
}

// The pose correctives as kept (joint, vertex) blocks of a per-joint low-rank basis
// (format/pose_correctives_codec.h): a Draco point cloud plus float32 mixing rows.
void add_compact_pose_correctives(GlbDoc& d, const BodyModel& b, const PoseCorrectiveCodec& codec) {
  const EncodedPoseCorrectives e = encode_pose_correctives(b.posedirs, b.num_verts, codec);
  const int mv = d.bin.add_view(e.mixing.data(), e.mixing.size() * sizeof(float));
  Json pc = {{"encoding", "sparse_lowrank"},
             {"count", e.count},
             {"rank", e.rank},
             {"threshold", codec.threshold},
             {"quantizationBits", codec.bits},
             {"mixingBufferView", mv},
             {"mixingCrc32", d.bin.view_crc(mv)}};
  d.sz.pose_correctives = d.bin.view_size(mv);
  if (e.count > 0) {  // Draco has no empty point cloud
    const int v = d.bin.add_view(e.draco.data(), e.draco.size());
    pc["bufferView"] = v;
    pc["crc32"] = d.bin.view_crc(v);
    pc["attributes"] = {{"JOINT", e.ids[0]}, {"VERTEX", e.ids[1]}, {"COEF_X", e.ids[2]}, {"COEF_Y", e.ids[3]}, {"COEF_Z", e.ids[4]}};
    d.sz.pose_correctives += d.bin.view_size(v);
  }
  d.ext["body"]["poseCorrectives"] = pc;
}

// Skin weights of each Gaussian for a skinning-aware splat renderer: its face's three
// vertex weights blended at the barycentric point of its rest centre projected onto the
// face (negative coordinates set to zero, then renormalised), the four largest kept, as
// unsigned-short codes summing to 65535, multiples of 257. Returns joints (N, 4), codes (N, 4).
void splat_skin(const Avatar& a, const RestBody& rest, const std::vector<float>& means, std::vector<uint8_t>& joints,
                std::vector<uint16_t>& codes) {
  const BodyModel& b = a.body;
  const BoundGaussians& G = a.gaussians;
  const size_t N = size_t(G.size());
  joints.assign(N * 4, 0);
  codes.assign(N * 4, 0);
  std::vector<double> w(kNumJoints);
  for (size_t i = 0; i < N; ++i) {
    const int32_t* fv = &b.faces[size_t(G.face[i]) * 3];
    Vec3d p[3];
    for (int c = 0; c < 3; ++c) p[c] = Vec3d(Vec3f::load(&rest.verts[size_t(fv[c]) * 3]));
    const Vec3d x(Vec3f::load(&means[i * 3]));
    const Vec3d e1 = p[1] - p[0], e2 = p[2] - p[0], q = x - p[0];
    const double d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2), den = d11 * d22 - d12 * d12;
    double bary[3] = {1.0 / 3, 1.0 / 3, 1.0 / 3};
    if (den > 1e-30 * std::max(1.0, d11 * d22)) {
      const double q1 = dot(q, e1), q2 = dot(q, e2);
      const double u = (d22 * q1 - d12 * q2) / den, v = (d11 * q2 - d12 * q1) / den;
      bary[0] = std::max(0.0, 1.0 - u - v);
      bary[1] = std::max(0.0, u);
      bary[2] = std::max(0.0, v);
      const double s = bary[0] + bary[1] + bary[2];
      for (double& c : bary) c /= s;
    }
    std::fill(w.begin(), w.end(), 0.0);
    for (int c = 0; c < 3; ++c)
      for (int j = 0; j < kNumJoints; ++j) w[size_t(j)] += bary[c] * b.weights[size_t(fv[c]) * kNumJoints + size_t(j)];
    std::vector<std::pair<float, int>> list;
    for (int j = 0; j < kNumJoints; ++j)
      if (w[size_t(j)] > 0) list.push_back({float(w[size_t(j)]), j});
    std::stable_sort(list.begin(), list.end(), [](auto& l, auto& r) { return l.first > r.first; });
    if (list.size() > 4) list.resize(4);
    if (list.empty()) list.push_back({1.0f, 0});
    // 8-bit codes summing to 255, stored times 257 (still summing to 65535): renderers that
    // keep 8 bits per weight (Spark) then read exactly the file's weights.
    const std::vector<uint16_t> c = weight_codes(list, 16, 255);
    for (size_t k = 0; k < list.size(); ++k) {
      joints[i * 4 + k] = uint8_t(list[k].second);
      codes[i * 4 + k] = uint16_t(c[k] * 257);
    }
  }
}

// A KHR_gaussian_splatting primitive of the rest-pose world Gaussians (the face frames of
// the baked rest mesh), for viewers that know only that extension; skinned by the body's
// skin (per-splat JOINTS_0 / WEIGHTS_0), so a skinning-aware splat renderer moves them.
void add_rest_splats(GlbDoc& d, const Avatar& a, const RestBody& rest) {
  const BoundGaussians& G = a.gaussians;
  const int N = G.size();
  std::vector<float> means(size_t(N) * 3), quats(size_t(N) * 4), scales(size_t(N) * 3);
  pose_gaussians(rest.verts.data(), a.body, a.face_scale_divisor, G, means.data(), quats.data(), scales.data());
  std::vector<float> xyzw(size_t(N) * 4), op(G.opacity), sh0(size_t(N) * 3);
  for (int i = 0; i < N; ++i) {
    const float* q = &quats[size_t(i) * 4];
    const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    for (int k = 0; k < 3; ++k) xyzw[size_t(i) * 4 + k] = float(q[k + 1] / n);
    xyzw[size_t(i) * 4 + 3] = float(q[0] / n);
    for (int k = 0; k < 3; ++k) sh0[size_t(i) * 3 + k] = float((G.color[size_t(i) * 3 + k] - 0.5) / 0.28209479177387814);
  }
  std::vector<uint8_t> joints;
  std::vector<uint16_t> codes;
  splat_skin(a, rest, means, joints, codes);
  const size_t before = d.bin.bytes().size();
  auto view_acc = [&](const void* data, size_t bytes, int type, const char* shape, bool normalized = false) {
    const int v = d.bin.add_view(data, bytes, 4, kArrayBuffer);
    Json acc = {{"bufferView", v}, {"componentType", type}, {"count", N}, {"type", shape}};
    if (normalized) acc["normalized"] = true;
    return d.add_accessor(acc);
  };
  Json sattrs;
  sattrs["POSITION"] = d.add_accessor(position_bounds(means, {{"bufferView", d.bin.add_view(means.data(), means.size() * 4, 4, kArrayBuffer)},
                                                             {"componentType", kFloat}, {"count", N}, {"type", "VEC3"}}));
  sattrs["KHR_gaussian_splatting:ROTATION"] = view_acc(xyzw.data(), xyzw.size() * 4, kFloat, "VEC4");
  sattrs["KHR_gaussian_splatting:SCALE"] = view_acc(scales.data(), scales.size() * 4, kFloat, "VEC3");
  sattrs["KHR_gaussian_splatting:OPACITY"] = view_acc(op.data(), op.size() * 4, kFloat, "SCALAR");
  sattrs["KHR_gaussian_splatting:SH_DEGREE_0_COEF_0"] = view_acc(sh0.data(), sh0.size() * 4, kFloat, "VEC3");
  sattrs["JOINTS_0"] = view_acc(joints.data(), joints.size(), kUByte, "VEC4");
  sattrs["WEIGHTS_0"] = view_acc(codes.data(), codes.size() * 2, kUShort, "VEC4", true);
  d.sz.splats = d.bin.bytes().size() - before;
  d.meshes.push_back({{"name", "gaussians"},
                      {"primitives", Json::array({{{"attributes", sattrs},
                                                   {"mode", 0},
                                                   {"extensions", {{"KHR_gaussian_splatting", {{"kernel", "ellipse"}, {"colorSpace", "srgb_rec709_display"}}}}}}})}});
  const int splat_node = int(d.nodes.size());
  d.nodes.push_back({{"name", "gaussians"}, {"mesh", 1}, {"skin", 0}});
  d.scene_nodes.push_back(splat_node);
  d.used.push_back("KHR_gaussian_splatting");
  d.ext["splats"] = {{"mesh", 1}, {"node", splat_node}};
}

}  // namespace

std::vector<uint8_t> pack_avatar(const Avatar& a, const PackOptions& opt, PackedSizes* sizes_out) {
  validate_avatar(a, "avatar");
  const BodyModel& b = a.body;
  if (b.vt.empty() || b.ft.size() != size_t(b.num_faces) * 3) {
    fail("avatar", "body model has no UV map (vt/ft), which the texture needs");
  }
  if (opt.lossless && opt.lod_tiers > 1) fail("--lod", "tiers reorder the Gaussians; --lossless keeps the trainer's order");
  if (opt.lossless && opt.mesh_compression != MeshCompression::draco) {
    fail("--mesh-compression", "--lossless stores bit-exact Draco streams; 'none' is for engines (drop one of the two)");
  }
  if (opt.lossless && opt.texture_size > 0 && (opt.texture_size != a.texture.width || opt.texture_size != a.texture.height)) {
    fail("--texture-size", "--lossless keeps the trained texture (" + std::to_string(a.texture.width) + " x " +
                               std::to_string(a.texture.height) + "); a different size cannot be lossless");
  }
  GlbDoc d;
  d.sz.num_gaussians = a.gaussians.size();
  d.sz.num_faces = b.num_faces;
  d.ext["version"] = kAvatarFormatVersion;
  d.ext["subject"] = {{"betas", float_array(a.betas.data(), a.betas.size())},
                      {"expression", float_array(a.expression.data(), a.expression.size())}};
  d.ext["faceFrame"] = {{"scaleDivisor", glb::json_float(a.face_scale_divisor)}};
  if (a.depth_margin != 0.0f) d.ext["depthTest"] = {{"margin", glb::json_float(a.depth_margin)}};  // absent: exact

  // The parts, in file order.
  const RestBody rest = rest_body(a);
  add_body_mesh(d, a, rest, opt);
  add_skeleton(d, b, rest, opt.lossless);
  add_texture(d, a, opt);
  add_gaussians(d, a, opt);
  if (opt.lossless) add_exact_texture(d, a);
  if (opt.pose_correctives == PoseCorrectives::dense) {
    add_pose_correctives(d, b, opt.lossless);
  } else if (opt.pose_correctives == PoseCorrectives::compact && !opt.lossless && !b.posedirs.empty()) {
    add_compact_pose_correctives(d, b, opt.pose_corrective_codec);
  }
  if (opt.khr_gaussian_splatting && a.gaussians.size() > 0) add_rest_splats(d, a, rest);  // glTF has no empty accessor
  Json animations;
  if (!opt.animations.empty()) {
    std::vector<size_t> each;
    animations = pack_animations(d.bin, d.accessors, opt.animations, rest.joints, opt.animation_bits, &each);
    for (size_t b : each) d.sz.animations += b;
  }

  Json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", "haha pack (HAHA_gaussian_avatar v" + std::to_string(kAvatarFormatVersion) + ")"}};
  gltf["extensionsUsed"] = d.used;
  if (!d.required.empty()) gltf["extensionsRequired"] = d.required;
  gltf["extensions"] = {{kAvatarExtension, d.ext}};
  gltf["scene"] = 0;
  gltf["scenes"] = Json::array({{{"name", "avatar"}, {"nodes", d.scene_nodes}}});
  gltf["nodes"] = d.nodes;
  gltf["meshes"] = d.meshes;
  gltf["skins"] = d.skins;
  gltf["materials"] = d.materials;
  gltf["textures"] = Json::array({d.texture});
  gltf["samplers"] = d.samplers;
  gltf["images"] = d.images;
  gltf["accessors"] = d.accessors;
  gltf["bufferViews"] = d.bin.views();
  gltf["buffers"] = Json::array({{{"byteLength", d.bin.bytes().size()}}});
  if (!animations.is_null()) gltf["animations"] = animations;

  std::vector<uint8_t> out = glb::write_glb(gltf, d.bin.bytes());
  d.sz.total = out.size();
  d.sz.json = out.size() - ((d.bin.bytes().size() + 3) / 4 * 4) - 28;
  if (sizes_out) *sizes_out = d.sz;
  return out;
}

namespace {

// "14" (every key) or "offset=14,rotation=12": bits per named attribute, 0 = float32.
void parse_bits(const std::string& text, const std::string& option, std::map<std::string, int*> keys) {
  auto number = [&](const std::string& s) {
    char* end = nullptr;
    const long v = std::strtol(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || v < 0 || v > 30) fail(option, "bits must be an integer in 0..30 (0 = float32), got '" + s + "'");
    return int(v);
  };
  if (text.find('=') == std::string::npos) {
    const int b = number(text);
    for (auto& [k, p] : keys) *p = b;
    return;
  }
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    if (eq == std::string::npos || !keys.count(key)) {
      std::string known;
      for (auto& [k, p] : keys) known += (known.empty() ? "" : ", ") + k;
      fail(option, "unknown entry '" + item + "' (keys: " + known + ")");
    }
    *keys[key] = number(item.substr(eq + 1));
  }
}

}  // namespace

GaussianBits parse_gaussian_bits(const std::string& text, const std::string& option, GaussianBits g) {
  parse_bits(text, option, {{"offset", &g.offset}, {"rotation", &g.rotation}, {"scale", &g.scale}, {"color", &g.color}, {"opacity", &g.opacity}});
  return g;
}

MeshBits parse_mesh_bits(const std::string& text, const std::string& option, MeshBits m) {
  parse_bits(text, option, {{"position", &m.position}, {"normal", &m.normal}, {"texcoord", &m.texcoord}, {"weight", &m.weight}});
  return m;
}

PackedSizes write_avatar_glb(const Avatar& avatar, const std::string& path, const PackOptions& options) {
  PackedSizes sz;
  const std::vector<uint8_t> bytes = pack_avatar(avatar, options, &sz);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!f) fail(path, "cannot write");
  });
  return sz;
}

}  // namespace haha
