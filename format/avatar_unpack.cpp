#include "format/avatar_unpack.h"
#include "format/animation_unpack.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>
#include <set>

#include "core/error.h"
#include "format/avatar_validate.h"
#include "format/canonical_faces.h"
#include "format/draco_io.h"
#include "format/gaussian_lod.h"
#include "format/glb.h"
#include "format/image_codec.h"
#include "format/pose_correctives_codec.h"

namespace haha {

using glb::as_int;
using glb::as_number;
using glb::as_string;
using glb::element;
using glb::find_member;
using glb::Json;
using glb::member;

namespace {

constexpr int64_t kMaxCount = 20'000'000;  // sanity bound on any element count or index in the file
const std::set<std::string> kSupportedRequired = {"KHR_draco_mesh_compression", "EXT_texture_webp",
                                                  "KHR_materials_unlit", kAvatarExtension};

class Reader {
 public:
  Reader(const glb::Glb& g, std::string where, const UnpackOptions& opt) : g_(g), where_(std::move(where)), opt_(opt) {}

  // The bytes of a bufferView, CRC-checked against `crc` (member of `obj`).
  glb::ByteSpan view(const Json& obj, const char* view_key, const char* crc_key, const std::string& what) {
    const int64_t v = as_int(member(obj, view_key, where_, what), where_, what + "." + view_key, 0, kMaxCount);
    glb::ByteSpan s = glb::buffer_view(g_, int(v), where_);
    if (opt_.verify_checksums) {
      const int64_t crc = as_int(member(obj, crc_key, where_, what), where_, what + "." + crc_key, 0, 0xFFFFFFFFll);
      if (glb::crc32(s.data, s.size) != uint32_t(crc)) {
        fail(where_, what + ": checksum mismatch (the file is corrupt or was modified)");
      }
    }
    return s;
  }
  int64_t integer(const Json& obj, const char* key, const std::string& what, int64_t lo, int64_t hi) {
    return as_int(member(obj, key, where_, what), where_, what + "." + key, lo, hi);
  }
  const std::string& where() const { return where_; }

 private:
  const glb::Glb& g_;
  std::string where_;
  const UnpackOptions& opt_;
};

std::vector<std::string> string_list(const Json& root, const char* key, const std::string& where) {
  std::vector<std::string> out;
  const Json* a = find_member(root, key);
  if (!a) return out;
  if (!a->is_array()) fail(where, std::string(key) + ": not an array");
  for (size_t i = 0; i < a->size(); ++i) out.push_back(as_string((*a)[i], where, std::string(key) + "[" + std::to_string(i) + "]"));
  return out;
}

// Reads one file part by part into `out`; each part's reader checks what it reads and
// names the JSON path of anything wrong.
class AvatarReader {
 public:
  AvatarReader(const glb::Glb& g, const std::string& where, const UnpackOptions& opt, UnpackedAvatar& out)
      : g_(g), root_(g.json), where_(where), rd_(g, where, opt), opt_(opt), out_(out), info_(out.info), a_(out.avatar) {}

  void read() {
    header();
    body_mesh();
    skin_weights();
    skeleton();
    joint_regressor();
    pose_correctives();
    subject();
    gaussians();
    garment_faces_last();
    texture();
    splats();
    summary();
    validate_avatar(a_, where_);
  }

 private:
  // The body mesh's per-glTF-vertex arrays, from Draco or from accessors.
  struct MeshArrays {
    std::vector<float> pos, uv, uv_src;                // (Vg, 3), (Vg, 2), lossless: (Vg, 2)
    std::vector<int64_t> source;                       // body vertex of each glTF vertex
    std::vector<int32_t> faces;                        // (F, 3) glTF vertices
    std::vector<std::vector<int64_t>> joints;          // per set (Vg, 4)
    std::vector<std::vector<float>> weights;           // per set (Vg, 4), decoded
    std::vector<float> color;                          // COLOR_0 (Vg, 4) in [0, 1]; empty: none
  };

  int draco_id(const Json& map, const std::string& name, const std::string& what) const {
    return int(as_int(member(map, name.c_str(), where_, what), where_, what + "." + name, 0, 1 << 20));
  }

  // Required extensions, the avatar extension and its version.
  void header() {
    info_.sizes.json = g_.json_chunk_bytes;
    info_.extensions_used = string_list(root_, "extensionsUsed", where_);
    info_.extensions_required = string_list(root_, "extensionsRequired", where_);
    for (const std::string& e : info_.extensions_required) {
      if (!kSupportedRequired.count(e)) fail(where_, "requires glTF extension " + e + ", which this loader does not support");
    }
    const Json* exts = find_member(root_, "extensions");
    ext_ = exts ? find_member(*exts, kAvatarExtension) : nullptr;
    if (!ext_) fail(where_, std::string("not a HAHA avatar: the glTF has no ") + kAvatarExtension + " extension");
    if (!ext_->is_object()) fail(where_, E + ": not a JSON object");
    const Json& ver = member(*ext_, "version", where_, E);
    if (!ver.is_number_integer() || ver.get<int64_t>() < kOldestAvatarFormatVersion || ver.get<int64_t>() > kAvatarFormatVersion) {
      fail(where_, E + ": unsupported version " + ver.dump() + " (this loader reads versions " +
                       std::to_string(kOldestAvatarFormatVersion) + " to " + std::to_string(kAvatarFormatVersion) + ")");
    }
    info_.version = int(ver.get<int64_t>());
    jb_ = &member(*ext_, "body", where_, E);
  }

  // The body mesh (Draco or plain accessors): rest vertices, faces, UVs (vertices split at
  // seams are merged back through _BODY_VERTEX), and the faces in the order the Gaussians
  // name them. Its primitives are one mesh: primitive 0's triangles, then a garment's
  // (primitive 1, version 4).
  void body_mesh() {
    const Json& jb = *jb_;
    const int64_t mesh_index = rd_.integer(jb, "mesh", B, 0, kMaxCount);
    V_ = rd_.integer(jb, "vertexCount", B, 1, kMaxCount);
    F_ = rd_.integer(jb, "faceCount", B, 1, kMaxCount);
    skin_sets_ = rd_.integer(*jb_, "skinSets", B, 1, 14);
    const Json& mesh = element(root_, "meshes", mesh_index, where_);
    const Json& prims = member(mesh, "primitives", where_, "meshes[" + std::to_string(mesh_index) + "]");
    if (!prims.is_array() || prims.empty()) fail(where_, "body mesh: no primitives");
    if (prims.size() > 2) fail(where_, "body mesh: " + std::to_string(prims.size()) + " primitives (the body and at most a garment)");
    jd_ = find_member(jb, "draco");
    jg_ = find_member(jb, "garment");
    if (jg_) {
      const std::string G = B + ".garment";
      info_.garment_first_vertex = int(rd_.integer(*jg_, "firstVertex", G, 1, V_ - 1));
      info_.garment_first_face = int(rd_.integer(*jg_, "firstFace", G, 1, F_ - 1));
      info_.garment_gaussians = int(rd_.integer(*jg_, "gaussians", G, 0, kMaxCount));
    }
    if (prims.size() > 1 && (!jg_ || info_.version < 4)) fail(where_, "body mesh: a second primitive, but no " + B + ".garment (version 4)");
    faces_in_file_order_ = info_.version < 3;
    MeshArrays all;
    for (size_t p = 0; p < prims.size(); ++p) {
      // Faces of this primitive: the garment's from body.garment.firstFace on.
      const int64_t first = p == 0 ? 0 : info_.garment_first_face, last = prims.size() == 1 || p == 1 ? F_ : info_.garment_first_face;
      mesh_primitive(prims[p], "meshes[" + std::to_string(mesh_index) + "].primitives[" + std::to_string(p) + "]", p, last - first);
      // The coverage is one per body vertex, garment included: all primitives or none.
      if (p > 0 && all.color.empty() != m_.color.empty()) fail(where_, P_ + ": COLOR_0 on some body mesh primitives but not on all");
      append_primitive(all, m_);
    }
    m_ = std::move(all);
    Vg_ = int(m_.source.size());
    if (m_.pos.size() != size_t(Vg_) * 3 || m_.uv.size() != size_t(Vg_) * 2 || (!m_.uv_src.empty() && m_.uv_src.size() != size_t(Vg_) * 2)) {
      fail(where_, "body mesh: its primitives disagree on their attributes");
    }
    if (const Json* qb = jd_ ? find_member(*jd_, "quantizationBits") : nullptr) {
      if (qb->is_object())
        for (auto& [k, v] : qb->items()) info_.mesh_bits[k] = int(as_int(v, where_, B + ".draco.quantizationBits." + k, 0, 30));
    }
    if (int64_t(m_.faces.size()) != F_ * 3) {
      fail(where_, "body mesh: " + std::to_string(m_.faces.size() / 3) + " faces, the file says " + std::to_string(F_));
    }
    if (Vg_ < V_) fail(where_, "body mesh: fewer glTF vertices than body vertices");
    if (jg_) garment_vertices_last();
    body_arrays_from_mesh();
    mesh_coverage(mesh_index);
  }

  // One primitive (Draco or plain accessors) into m_, `faces` triangles expected; its
  // Draco stream is named by body.draco (primitive 0) or body.garment.draco (primitive 1).
  void mesh_primitive(const Json& prim, const std::string& path, size_t p, int64_t faces) {
    P_ = path;
    m_ = MeshArrays();
    expected_faces_ = faces;
    if (const Json* mode = find_member(prim, "mode"); mode && as_int(*mode, where_, P_ + ".mode", 0, 6) != 4) {
      fail(where_, P_ + ": not a triangle list (mode " + mode->dump() + ")");
    }
    pattrs_ = &member(prim, "attributes", where_, P_);
    const Json* pext = find_member(prim, "extensions");
    const Json* kdraco = pext ? find_member(*pext, "KHR_draco_mesh_compression") : nullptr;
    jrec_ = p == 0 ? jd_ : find_member(*jg_, "draco");
    if (p == 0 && info_.version < 3 && (!kdraco || !jd_)) fail(where_, P_ + ": not Draco-compressed (KHR_draco_mesh_compression missing)");
    if (kdraco && !jrec_) rewritten_ = true;  // a tool re-encoded it: no stream of haha's
    if (kdraco) draco_body_mesh(*kdraco);
    else plain_body_mesh(prim);
    if (p == 0) info_.sizes.draco_mesh = kdraco != nullptr;
    if (int64_t(m_.faces.size()) != faces * 3) {
      fail(where_, P_ + ": " + std::to_string(m_.faces.size() / 3) + " faces, the file says " + std::to_string(faces));
    }
  }

  // Appends a primitive's arrays to the whole mesh's (its face indices shifted past the
  // glTF vertices before it).
  static void append_primitive(MeshArrays& all, const MeshArrays& p) {
    const int32_t shift = int32_t(all.source.size());
    auto cat = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    cat(all.pos, p.pos);
    cat(all.uv, p.uv);
    cat(all.uv_src, p.uv_src);
    cat(all.source, p.source);
    cat(all.color, p.color);
    for (int32_t c : p.faces) all.faces.push_back(c + shift);
    all.joints.resize(p.joints.size());
    all.weights.resize(p.weights.size());
    for (size_t s = 0; s < p.joints.size(); ++s) cat(all.joints[s], p.joints[s]);
    for (size_t s = 0; s < p.weights.size(); ++s) cat(all.weights[s], p.weights[s]);
  }

  // body.garment: its faces must use only its vertices (and the body's faces only the
  // body's; version-3 edgebreaker files list them in any order, the face order the
  // Gaussians name puts the garment's last: garment_faces_last); the glTF vertices are
  // ordered body first (version 3 mixed seam duplicates), so the unpacked body's UVs are
  // the body's, then the garment's (BodyModel::garment_first_uv).
  void garment_vertices_last() {
    const std::string G = B + ".garment";
    const int64_t gv = info_.garment_first_vertex, gf = info_.garment_first_face;
    const double chart = as_number(member(*jg_, "chart", where_, G), where_, G + ".chart");
    if (!(chart > 0 && chart <= 0.5)) fail(where_, G + ".chart: not in (0, 0.5]");
    int64_t garment_faces = 0;
    for (size_t f = 0; f < m_.faces.size() / 3; ++f) {
      int on = 0;
      for (size_t k = 0; k < 3; ++k) on += m_.source[size_t(m_.faces[f * 3 + k])] >= gv;
      if (on % 3) fail(where_, G + ": face " + std::to_string(f) + " joins the body's and the garment's vertices");
      garment_faces += on / 3;
    }
    if (garment_faces != F_ - gf) fail(where_, G + ": " + std::to_string(garment_faces) + " faces on the garment's vertices, the file says " + std::to_string(F_ - gf));
    std::vector<int32_t> order, at(static_cast<size_t>(Vg_));
    for (int garment = 0; garment < 2; ++garment) {
      for (int gi = 0; gi < Vg_; ++gi)
        if ((m_.source[size_t(gi)] >= gv) == bool(garment)) {
          at[size_t(gi)] = int32_t(order.size());
          order.push_back(gi);
        }
      if (!garment) garment_first_uv_ = int(order.size());
    }
    auto permuted = [&](const auto& v, size_t comps) {
      std::remove_cvref_t<decltype(v)> out(v.size());
      for (size_t i = 0; i < order.size() && !v.empty(); ++i)
        for (size_t k = 0; k < comps; ++k) out[i * comps + k] = v[size_t(order[i]) * comps + k];
      return out;
    };
    m_.pos = permuted(m_.pos, 3);
    m_.uv = permuted(m_.uv, 2);
    m_.uv_src = permuted(m_.uv_src, 2);
    m_.source = permuted(m_.source, 1);
    m_.color = permuted(m_.color, 4);
    for (auto& j : m_.joints) j = permuted(j, 4);
    for (auto& w : m_.weights) w = permuted(w, 4);
    for (int32_t& c : m_.faces) c = at[size_t(c)];
    garment_chart_ = float(chart);
  }

  // The body model's arrays from the whole mesh's glTF vertices and faces, and where its
  // garment starts.
  void body_arrays_from_mesh() {
    BodyModel& body = a_.body;
    body.source = where_;
    body.num_verts = int(V_);
    body.num_faces = int(F_);
    body.v_template.assign(size_t(V_) * 3, 0.0f);
    std::vector<char> seen(size_t(V_), 0);
    for (int gi = 0; gi < Vg_; ++gi) {
      const int64_t s = m_.source[size_t(gi)];
      if (s < 0 || s >= V_) fail(where_, "body mesh: _BODY_VERTEX " + std::to_string(s) + " out of range [0, " + std::to_string(V_) + ")");
      if (!seen[size_t(s)]) {
        seen[size_t(s)] = 1;
        for (int k = 0; k < 3; ++k) body.v_template[size_t(s) * 3 + k] = m_.pos[size_t(gi) * 3 + k];
      }
    }
    for (int64_t v = 0; v < V_; ++v)
      if (!seen[size_t(v)]) fail(where_, "body mesh: body vertex " + std::to_string(v) + " has no glTF vertex");
    body.faces.resize(m_.faces.size());
    for (size_t c = 0; c < m_.faces.size(); ++c) body.faces[c] = int32_t(m_.source[size_t(m_.faces[c])]);
    body.ft = m_.faces;
    body.vt.resize(size_t(Vg_) * 2);
    for (int gi = 0; gi < Vg_; ++gi) {
      if (!m_.uv_src.empty()) {
        body.vt[size_t(gi) * 2] = m_.uv_src[size_t(gi) * 2];
        body.vt[size_t(gi) * 2 + 1] = m_.uv_src[size_t(gi) * 2 + 1];
      } else {
        body.vt[size_t(gi) * 2] = m_.uv[size_t(gi) * 2];
        body.vt[size_t(gi) * 2 + 1] = 1.0f - m_.uv[size_t(gi) * 2 + 1];  // back to the body model's v-up UVs
      }
    }
    if (jg_) {  // the unpacked avatar carries its garment as the trainer's did (body/garment.h)
      body.garment_first_vert = info_.garment_first_vertex;
      body.garment_first_face = info_.garment_first_face;
      body.garment_first_uv = garment_first_uv_;
      body.garment_chart = garment_chart_;
    }
  }

  // The mesh coverage (Avatar::mesh_coverage) from COLOR_0's alpha: white (the texture alone
  // colours the mesh), the same alpha on every glTF vertex of a body vertex, and a material
  // that cuts where haha does (alphaMode MASK at kCoverageCutoff); no COLOR_0, no MASK.
  void mesh_coverage(int64_t mesh_index) {
    const std::string P = "meshes[" + std::to_string(mesh_index) + "]";
    const std::string mask = coverage_material(mesh_index);
    if (m_.color.empty()) {
      if (!mask.empty()) fail(where_, mask + ": alphaMode MASK, but the body mesh has no COLOR_0 (the mesh coverage)");
      return;
    }
    if (mask.empty()) fail(where_, P + ": COLOR_0 (the mesh coverage) without its material's alphaMode MASK");
    if (m_.color.size() != size_t(Vg_) * 4) fail(where_, P + ": COLOR_0 does not cover every glTF vertex");
    std::vector<float>& c = a_.mesh_coverage;
    c.assign(size_t(V_), -1.0f);
    for (int gi = 0; gi < Vg_; ++gi) {
      const float* rgba = &m_.color[size_t(gi) * 4];
      const size_t v = size_t(m_.source[size_t(gi)]);
      if (rgba[0] != 1.0f || rgba[1] != 1.0f || rgba[2] != 1.0f) {
        fail(where_, P + ": COLOR_0 of body vertex " + std::to_string(v) + " is not white (only its alpha, the mesh coverage, may vary)");
      }
      if (!(rgba[3] >= 0.0f && rgba[3] <= 1.0f)) fail(where_, P + ": COLOR_0 alpha of body vertex " + std::to_string(v) + " is not in [0, 1]");
      if (c[v] >= 0.0f && c[v] != rgba[3]) {
        fail(where_, P + ": COLOR_0 alpha of body vertex " + std::to_string(v) + " differs between its glTF vertices (seam duplicates)");
      }
      c[v] = rgba[3];
    }
    m_.color.clear();
  }

  // The body primitives' material when it cuts by alpha (alphaMode MASK): its JSON path, after
  // checking the cutoff is kCoverageCutoff; "" for OPAQUE (or BLEND: drawn whole by haha).
  std::string coverage_material(int64_t mesh_index) {
    const Json& prims = member(element(root_, "meshes", mesh_index, where_), "primitives", where_, "body mesh");
    std::string found;
    for (size_t p = 0; p < prims.size(); ++p) {
      const Json* m = find_member(prims[p], "material");
      if (!m) continue;
      const int64_t mi = as_int(*m, where_, "body mesh material", 0, kMaxCount);
      const Json& mat = element(root_, "materials", mi, where_);
      const std::string M = "materials[" + std::to_string(mi) + "]";
      const Json* mode = find_member(mat, "alphaMode");
      if (!mode || as_string(*mode, where_, M + ".alphaMode") != "MASK") continue;
      const Json* cut = find_member(mat, "alphaCutoff");
      const double cutoff = cut ? as_number(*cut, where_, M + ".alphaCutoff") : 0.5;  // glTF's default
      if (cutoff != double(kCoverageCutoff)) {
        fail(where_, M + ".alphaCutoff: " + std::to_string(cutoff) + ", the mesh coverage cuts at " + std::to_string(kCoverageCutoff));
      }
      found = M;
    }
    return found;
  }

  // The KHR_draco_mesh_compression stream into m_ (versions 1-2: the vertex map is the
  // private BODY_VERTEX; version 3: the primitive's _BODY_VERTEX).
  void draco_body_mesh(const Json& kdraco) {
    const std::string K = P_ + ".KHR_draco_mesh_compression";
    const int64_t stream_view = rd_.integer(kdraco, "bufferView", K, 0, kMaxCount);
    glb::ByteSpan mesh_bytes;
    const std::string D = jrec_ == jd_ ? B + ".draco" : B + ".garment.draco";
    if (jrec_) {
      if (rd_.integer(*jrec_, "bufferView", D, 0, kMaxCount) != stream_view) {
        fail(where_, D + ": bufferView differs from the primitive's Draco stream");
      }
      mesh_bytes = rd_.view(*jrec_, "bufferView", "crc32", D);
    } else {
      mesh_bytes = glb::buffer_view(g_, int(stream_view), where_);  // rewritten by a tool: no checksum
    }
    info_.sizes.mesh += mesh_bytes.size;
    const Json& pos_acc = element(root_, "accessors", as_int(member(*pattrs_, "POSITION", where_, P_ + ".attributes"), where_,
                                                             P_ + ".attributes.POSITION", 0, kMaxCount), where_);
    const int64_t gltf_verts = as_int(member(pos_acc, "count", where_, "POSITION accessor"), where_, "POSITION accessor.count", 1, kMaxCount);
    const dracoio::Decoded dec(mesh_bytes.data, mesh_bytes.size, true, where_, "body mesh", gltf_verts, expected_faces_);
    Vg_ = dec.num_points();
    edgebreaker_ = edgebreaker_ || dec.method() == dracoio::Method::edgebreaker;
    info_.sizes.edgebreaker = edgebreaker_;
    if (edgebreaker_ && info_.version < 2) fail(where_, "body mesh: edgebreaker-encoded, which version 1 files never are");
    if (dec.num_faces() != expected_faces_) {
      fail(where_, P_ + ": Draco stream has " + std::to_string(dec.num_faces()) + " faces, the file says " + std::to_string(expected_faces_));
    }
    const Json& dattrs = member(kdraco, "attributes", where_, K);
    m_.pos = dec.floats(draco_id(dattrs, "POSITION", K), 3, "POSITION");
    m_.uv = draco_values(dec, dattrs, "TEXCOORD_0", 2);
    if (jrec_) {
      if (const Json* m = find_member(*jrec_, "method")) {
        const std::string method = as_string(*m, where_, D + ".method");
        if (method != (edgebreaker_ ? "edgebreaker" : "sequential")) {
          fail(where_, D + ".method: says '" + method + "' but the Draco stream is " + (edgebreaker_ ? "edgebreaker" : "sequential"));
        }
      }
    }
    const Json* mpriv = jrec_ ? find_member(*jrec_, "attributes") : nullptr;
    if (info_.version < 3) {
      if (!jrec_) fail(where_, B + ".draco: missing");
      m_.source = dec.ints(draco_id(member(*jrec_, "attributes", where_, D), "BODY_VERTEX", D + ".attributes"), 1, "BODY_VERTEX");
    } else {
      const int id = draco_id(dattrs, "_BODY_VERTEX", K);
      if (dec.is_float(id)) {  // exact integers in float (large meshes, or re-encoded plain files)
        for (float x : dec.floats(id, 1, "_BODY_VERTEX")) {
          if (x != std::floor(x) || !(std::fabs(x) < 2147483648.0f)) fail(where_, "body mesh: _BODY_VERTEX holds a non-integer value");
          m_.source.push_back(int64_t(x));
        }
      } else {
        m_.source = dec.ints(id, 1, "_BODY_VERTEX");
      }
    }
    if (mpriv && find_member(*mpriv, "TEXCOORD_SOURCE")) {
      m_.uv_src = dec.floats(draco_id(*mpriv, "TEXCOORD_SOURCE", D + ".attributes"), 2, "TEXCOORD_SOURCE");
    }
    m_.faces = dec.faces();
    for (int64_t s = 0; s < skin_sets_; ++s) {
      const std::string jn = "JOINTS_" + std::to_string(s), wn = "WEIGHTS_" + std::to_string(s);
      m_.joints.push_back(dec.ints(draco_id(dattrs, jn, K), 4, jn));
      m_.weights.push_back(draco_values(dec, dattrs, wn, 4));
    }
    if (find_member(*pattrs_, "COLOR_0")) {
      color_accessor_type();
      m_.color = draco_values(dec, dattrs, "COLOR_0", 4);
    }
  }

  // COLOR_0 holds the mesh coverage in its alpha: VEC4 (VEC3 has none), and a component
  // type glTF allows for colours.
  void color_accessor_type() {
    const std::string what = P_ + ".attributes.COLOR_0";
    const Json& acc = element(root_, "accessors", as_int(member(*pattrs_, "COLOR_0", where_, P_ + ".attributes"), where_, what, 0, kMaxCount), where_);
    const std::string type = as_string(member(acc, "type", where_, what), where_, what + ".type");
    if (type != "VEC4") fail(where_, what + ": type " + type + ", expected VEC4 (the mesh coverage is its alpha)");
    const int64_t ct = as_int(member(acc, "componentType", where_, what), where_, what + ".componentType", 5120, 5126);
    const Json* n = find_member(acc, "normalized");
    const bool normalized = n && n->is_boolean() && n->get<bool>();
    if (!(ct == 5126 || ((ct == 5121 || ct == 5123) && normalized))) {
      fail(where_, what + ": componentType " + std::to_string(ct) + " (glTF colours are float or normalized unsigned byte / short)");
    }
  }

  // A decoded Draco attribute as the primitive's accessor says it is stored: float, or
  // normalized unsigned integers (weights; UVs of a plain file a tool re-encoded).
  std::vector<float> draco_values(const dracoio::Decoded& dec, const Json& dattrs, const std::string& name, int comps) {
    const std::string K = P_ + ".KHR_draco_mesh_compression";
    const Json& acc = element(root_, "accessors", as_int(member(*pattrs_, name.c_str(), where_, P_ + ".attributes"), where_,
                                                         P_ + ".attributes." + name, 0, kMaxCount), where_);
    const int64_t type = as_int(member(acc, "componentType", where_, name + " accessor"), where_, name + " accessor.componentType", 5120, 5126);
    const int id = draco_id(dattrs, name, K);
    if (type == 5126) return dec.floats(id, comps, name);
    const Json* n = find_member(acc, "normalized");
    if ((type != 5121 && type != 5123) || !n || !n->is_boolean() || !n->get<bool>()) {
      fail(where_, name + " accessor: componentType " + std::to_string(type) + " (not float or normalized unsigned byte / short)");
    }
    const double full = type == 5121 ? 255.0 : 65535.0;
    std::vector<float> out;
    for (int64_t c : dec.ints(id, comps, name)) out.push_back(float(double(c) / full));
    return out;
  }

  // Plain accessors into m_ (version 3; any layout glTF allows, e.g. as rewritten by tools).
  void plain_body_mesh(const Json& prim) {
    auto attribute = [&](const char* name, int comps) {
      return glb::read_accessor(g_, as_int(member(*pattrs_, name, where_, P_ + ".attributes"), where_, P_ + ".attributes." + name, 0, kMaxCount),
                                comps, where_, P_ + ".attributes." + name);
    };
    auto to_floats = [](const std::vector<double>& v) { return std::vector<float>(v.begin(), v.end()); };
    const glb::AccessorValues pos = attribute("POSITION", 3);
    if (pos.count > kMaxCount) fail(where_, "body mesh: too many vertices");
    Vg_ = int(pos.count);
    m_.pos = to_floats(pos.values);
    auto check_count = [&](const glb::AccessorValues& a, const char* name) {
      if (a.count != pos.count) fail(where_, std::string("body mesh: ") + name + " has " + std::to_string(a.count) + " values, POSITION " + std::to_string(pos.count));
      return a;
    };
    m_.uv = to_floats(check_count(attribute("TEXCOORD_0", 2), "TEXCOORD_0").values);
    auto integers = [&](const glb::AccessorValues& a, const std::string& name) {
      if (a.component_type == 5126 || a.normalized) {
        for (double x : a.values)
          if (x != std::floor(x) || !(std::fabs(x) < 2147483648.0)) fail(where_, "body mesh: " + name + " holds a non-integer value");
      }
      return std::vector<int64_t>(a.values.begin(), a.values.end());
    };
    m_.source = integers(check_count(attribute("_BODY_VERTEX", 1), "_BODY_VERTEX"), "_BODY_VERTEX");
    for (int64_t s = 0; s < skin_sets_; ++s) {
      const std::string jn = "JOINTS_" + std::to_string(s), wn = "WEIGHTS_" + std::to_string(s);
      m_.joints.push_back(integers(check_count(attribute(jn.c_str(), 4), jn.c_str()), jn));
      m_.weights.push_back(to_floats(check_count(attribute(wn.c_str(), 4), wn.c_str()).values));
    }
    if (find_member(*pattrs_, "COLOR_0")) {
      color_accessor_type();
      m_.color = to_floats(check_count(attribute("COLOR_0", 4), "COLOR_0").values);
    }
    if (const Json* ind = find_member(prim, "indices")) {
      const glb::AccessorValues idx = glb::read_accessor(g_, as_int(*ind, where_, P_ + ".indices", 0, kMaxCount), 1, where_, P_ + ".indices");
      for (double x : idx.values) {
        if (!(x >= 0 && x < double(Vg_))) fail(where_, "body mesh: index " + std::to_string(int64_t(x)) + " out of range");
        m_.faces.push_back(int32_t(x));
      }
    } else {
      for (int i = 0; i < Vg_; ++i) m_.faces.push_back(i);
    }
    for (int64_t i = 0; i < pos.count; ++i) {
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(m_.pos[size_t(i) * 3 + k])) fail(where_, "body mesh: non-finite POSITION at vertex " + std::to_string(i));
    }
    if (m_.faces.size() % 3) fail(where_, "body mesh: index count is not a multiple of 3");
    // Bytes of the bufferViews the mesh's accessors use, each counted once (a tool may
    // interleave several attributes in one).
    std::set<int64_t> views;
    auto add_view_of = [&](const Json& index, const std::string& what) {
      const Json& acc = element(root_, "accessors", as_int(index, where_, what, 0, kMaxCount), where_);
      if (const Json* bv = find_member(acc, "bufferView")) views.insert(as_int(*bv, where_, what + ".bufferView", 0, kMaxCount));
    };
    for (auto& [k, v] : pattrs_->items()) add_view_of(v, P_ + ".attributes." + k);
    if (const Json* ind = find_member(prim, "indices")) add_view_of(*ind, P_ + ".indices");
    for (int64_t v : views) info_.sizes.mesh += glb::buffer_view(g_, int(v), where_).size;
  }

  // Skinning weights: every JOINTS_n/WEIGHTS_n set scattered back to the dense (V, 55) array.
  void skin_weights() {
    BodyModel& body = a_.body;
    body.weights.assign(size_t(V_) * kNumJoints, 0.0f);
    // Versions 1-2 stored Draco-quantized float weights whose sums are off by up to ~1e-3.
    const bool renormalise = info_.version < 3 && info_.mesh_bits.count("WEIGHTS") && info_.mesh_bits["WEIGHTS"] > 0;
    std::vector<char> done(size_t(V_), 0);
    for (int gi = 0; gi < Vg_; ++gi) {
      const size_t v = size_t(m_.source[size_t(gi)]);
      if (done[v]) continue;  // seam duplicates carry the same skin
      done[v] = 1;
      double sum = 0;
      for (int64_t s = 0; s < skin_sets_; ++s)
        for (int k = 0; k < 4; ++k) {
          const int64_t j = m_.joints[size_t(s)][size_t(gi) * 4 + k];
          const float w = m_.weights[size_t(s)][size_t(gi) * 4 + k];
          if (j < 0 || j >= kNumJoints) fail(where_, "body mesh: " + ("JOINTS_" + std::to_string(s)) + " index " + std::to_string(j) + " out of range");
          if (!std::isfinite(w) || w < -1e-3f) fail(where_, "body mesh: invalid skinning weight at vertex " + std::to_string(v));
          if (w != 0.0f) body.weights[v * kNumJoints + size_t(j)] += w;
          sum += w;
        }
      if (renormalise) {  // quantization moved the sum off 1: renormalise (and drop noise)
        if (!(sum > 0)) fail(where_, "body mesh: vertex " + std::to_string(v) + " has no skinning weight");
        for (int j = 0; j < kNumJoints; ++j) {
          float& w = body.weights[v * kNumJoints + size_t(j)];
          w = w > 0 ? float(w / sum) : 0.0f;
        }
      }
    }
    m_.joints.clear();
    m_.weights.clear();
  }

  // Joint parents from the node tree of the skin's joints.
  void skeleton() {
    const int64_t skin_index = rd_.integer(*jb_, "skin", B, 0, kMaxCount);
    skin_ = &element(root_, "skins", skin_index, where_);
    const Json& joints = member(*skin_, "joints", where_, "skins[" + std::to_string(skin_index) + "]");
    if (!joints.is_array() || joints.size() != size_t(kNumJoints)) fail(where_, "skin: must have exactly 55 joints (SMPL-X)");
    const Json& nodes = member(root_, "nodes", where_, "glTF");
    if (!nodes.is_array()) fail(where_, "nodes: not an array");
    std::vector<int64_t> node_parent(nodes.size(), -1);
    for (size_t n = 0; n < nodes.size(); ++n) {
      if (const Json* ch = find_member(nodes[n], "children")) {
        if (!ch->is_array()) fail(where_, "nodes[" + std::to_string(n) + "].children: not an array");
        for (size_t i = 0; i < ch->size(); ++i) {
          const int64_t c = as_int((*ch)[i], where_, "nodes[" + std::to_string(n) + "].children", 0, int64_t(nodes.size()) - 1);
          if (node_parent[size_t(c)] >= 0) fail(where_, "nodes[" + std::to_string(c) + "]: has two parents");
          node_parent[size_t(c)] = int64_t(n);
        }
      }
    }
    std::vector<int64_t> joint_node(kNumJoints);
    for (int j = 0; j < kNumJoints; ++j) joint_node[size_t(j)] = as_int(joints[size_t(j)], where_, "skin.joints", 0, int64_t(nodes.size()) - 1);
    BodyModel& body = a_.body;
    body.parents.assign(kNumJoints, -1);
    for (int j = 0; j < kNumJoints; ++j) {
      const int64_t pn = node_parent[size_t(joint_node[size_t(j)])];
      for (int k = 0; k < kNumJoints; ++k)
        if (pn >= 0 && joint_node[size_t(k)] == pn) body.parents[size_t(j)] = k;
    }
  }

  // The sparse joint regressor (joint, vertex, weight), or (version 2 without one) the
  // rest joints from the inverse bind matrices; and the skeleton's byte count.
  void joint_regressor() {
    size_t ibm_bytes = 0;
    const Json* ibm = find_member(*skin_, "inverseBindMatrices");
    if (ibm) {
      const Json& acc = element(root_, "accessors", as_int(*ibm, where_, "skin.inverseBindMatrices", 0, kMaxCount), where_);
      if (const Json* bv = find_member(acc, "bufferView")) ibm_bytes = glb::buffer_view(g_, int(as_int(*bv, where_, "accessor.bufferView", 0, kMaxCount)), where_).size;
    }
    info_.sizes.skeleton += ibm_bytes;
    if (!find_member(*jb_, "jointRegressor")) {
      if (info_.version < 2) fail(where_, B + ".jointRegressor: missing");
      rest_joints_from_inverse_binds(ibm);
      return;
    }
    const Json& jr = member(*jb_, "jointRegressor", where_, B);
    const int64_t nnz = rd_.integer(jr, "count", B + ".jointRegressor", 0, kNumJoints * V_);
    const glb::ByteSpan jrb = rd_.view(jr, "bufferView", "crc32", B + ".jointRegressor");
    if (jrb.size != size_t(nnz) * 12) fail(where_, B + ".jointRegressor: bufferView has " + std::to_string(jrb.size) + " bytes, expected " + std::to_string(nnz * 12));
    info_.joint_regressor_nonzeros = int(nnz);
    BodyModel& body = a_.body;
    body.j_regressor.assign(size_t(kNumJoints) * V_, 0.0f);
    for (int64_t i = 0; i < nnz; ++i) {
      int32_t j, v;
      float w;
      std::memcpy(&j, jrb.data + i * 4, 4);
      std::memcpy(&v, jrb.data + nnz * 4 + i * 4, 4);
      std::memcpy(&w, jrb.data + nnz * 8 + i * 4, 4);
      if (j < 0 || j >= kNumJoints || v < 0 || v >= V_) fail(where_, B + ".jointRegressor: entry " + std::to_string(i) + " out of range");
      body.j_regressor[size_t(j) * V_ + size_t(v)] = w;
    }
    info_.sizes.skeleton += jrb.size;
  }

  // Joint j rests at minus the translation of its inverse bind matrix (spec section 2):
  // float negation is exact, so these are the packer's joints bit for bit.
  void rest_joints_from_inverse_binds(const Json* ibm) {
    const std::string what = "skin.inverseBindMatrices";
    if (!ibm) fail(where_, what + ": missing (a file without a joint regressor needs them for the rest joints)");
    const Json& acc = element(root_, "accessors", as_int(*ibm, where_, what, 0, kMaxCount), where_);
    if (rd_.integer(acc, "componentType", what, 0, kMaxCount) != 5126 || as_string(member(acc, "type", where_, what), where_, what + ".type") != "MAT4" ||
        rd_.integer(acc, "count", what, 0, kMaxCount) != kNumJoints) {
      fail(where_, what + ": must be 55 float MAT4");
    }
    const glb::ByteSpan s = glb::buffer_view(g_, int(rd_.integer(acc, "bufferView", what, 0, kMaxCount)), where_);
    const int64_t offset = find_member(acc, "byteOffset") ? rd_.integer(acc, "byteOffset", what, 0, kMaxCount) : 0;
    if (size_t(offset) + size_t(kNumJoints) * 64 > s.size) fail(where_, what + ": accessor runs past its bufferView");
    std::vector<float>& J = a_.body.joints_rest;
    J.resize(size_t(kNumJoints) * 3);
    for (int j = 0; j < kNumJoints; ++j)
      for (int k = 0; k < 3; ++k) {
        float t;
        std::memcpy(&t, s.data + offset + j * 64 + (12 + k) * 4, 4);
        if (!std::isfinite(t)) fail(where_, what + ": non-finite value");
        J[size_t(j) * 3 + k] = -t;
      }
  }

  // Whether the avatar was trained with correctives, and the embedded ones (optional).
  void pose_correctives() {
    const Json& jb = *jb_;
    if (const Json* t = find_member(jb, "trainedWithPoseCorrectives")) {
      if (!t->is_boolean()) fail(where_, B + ".trainedWithPoseCorrectives: not a boolean");
      info_.trained_with_pose_correctives = t->get<bool>();
    }
    if (const Json* t = find_member(jb, "topologyCrc32")) info_.topology_crc32 = uint32_t(as_int(*t, where_, B + ".topologyCrc32", 0, 0xFFFFFFFFll));
    const Json* pc = find_member(jb, "poseCorrectives");
    if (!pc) return;
    const std::string what = B + ".poseCorrectives";
    std::string encoding = "dense";  // version 1 and early version 2 files name no encoding
    if (const Json* e = find_member(*pc, "encoding")) encoding = as_string(*e, where_, what + ".encoding");
    if (encoding == "sparse_lowrank") return compact_pose_correctives(*pc, what);
    if (encoding != "dense") fail(where_, what + ".encoding: unknown '" + encoding + "'");
    const std::string type = as_string(member(*pc, "componentType", where_, what), where_, what + ".componentType");
    const size_t count = size_t(V_) * 3 * kNumPoseFeatures;
    const glb::ByteSpan s = rd_.view(*pc, "bufferView", "crc32", what);
    // The byte length is checked before allocating: the count comes from the vertex count.
    const size_t bytes_per_value = type == "float32" ? 4 : (type == "int16" ? 2 : 0);
    if (bytes_per_value == 0) fail(where_, what + ".componentType: unknown '" + type + "'");
    if (s.size != count * bytes_per_value) fail(where_, what + ": wrong byte length");
    std::vector<float>& posedirs = a_.body.posedirs;
    posedirs.resize(count);
    if (type == "float32") {
      std::memcpy(posedirs.data(), s.data, count * 4);
      info_.sizes.pose_correctives = s.size;
    } else {
      const glb::ByteSpan sc = rd_.view(*pc, "scaleBufferView", "scaleCrc32", what);
      if (sc.size != size_t(kNumPoseFeatures) * 4) fail(where_, what + ": wrong scale byte length");
      std::vector<float> scale(kNumPoseFeatures);
      std::memcpy(scale.data(), sc.data, sc.size);
      for (size_t i = 0; i < count; ++i) {
        int16_t q;
        std::memcpy(&q, s.data + i * 2, 2);
        posedirs[i] = float(q) * scale[i % kNumPoseFeatures];
      }
      info_.sizes.pose_correctives = s.size + sc.size;
    }
    info_.pose_correctives = type;
  }

  // "sparse_lowrank": kept (joint, vertex) blocks of a per-joint low-rank basis, expanded
  // to dense posedirs for LBS (format/pose_correctives_codec.h).
  void compact_pose_correctives(const Json& pc, const std::string& what) {
    const int64_t count = rd_.integer(pc, "count", what, 0, int64_t(V_) * (kNumJoints - 1));
    const int rank = int(rd_.integer(pc, "rank", what, 1, 9));
    const int bits = int(rd_.integer(pc, "quantizationBits", what, 0, 30));
    const glb::ByteSpan mix = rd_.view(pc, "mixingBufferView", "mixingCrc32", what + " mixing rows");
    if (mix.size != size_t(kNumJoints - 1) * rank * 9 * 4) fail(where_, what + ": wrong mixing-row byte length");
    std::vector<float> mixing(mix.size / 4);
    std::memcpy(mixing.data(), mix.data, mix.size);
    info_.sizes.pose_correctives = mix.size;
    glb::ByteSpan s{};
    int ids[5] = {-1, -1, -1, -1, -1};
    if (count > 0) {
      s = rd_.view(pc, "bufferView", "crc32", what);
      const Json& attrs = member(pc, "attributes", where_, what);
      const char* names[5] = {"JOINT", "VERTEX", "COEF_X", "COEF_Y", "COEF_Z"};
      for (int i = 0; i < 5; ++i) ids[i] = draco_id(attrs, names[i], what + ".attributes");
      info_.sizes.pose_correctives += s.size;
    } else if (find_member(pc, "bufferView")) {
      fail(where_, what + ": a point cloud for zero blocks");
    }
    a_.body.posedirs = decode_pose_correctives(s.data, s.size, int(count), rank, ids, mixing.data(), int(V_), where_, what);
    info_.pose_correctives = "sparse_lowrank";
    info_.pose_corrective_blocks = int(count);
    info_.pose_corrective_rank = rank;
    info_.pose_corrective_bits = bits;
  }

  // Betas and expression (already baked into the mesh), face frame scale, depth test.
  void subject() {
    const Json& ext = *ext_;
    const Json& subj = member(ext, "subject", where_, E);
    a_.betas = glb::as_float_array(member(subj, "betas", where_, E + ".subject"), where_, E + ".subject.betas", 400);
    a_.expression = glb::as_float_array(member(subj, "expression", where_, E + ".subject"), where_, E + ".subject.expression", 400);
    a_.face_scale_divisor = float(as_number(member(member(ext, "faceFrame", where_, E), "scaleDivisor", where_, E + ".faceFrame"),
                                            where_, E + ".faceFrame.scaleDivisor"));
    if (ext.contains("depthTest"))
      a_.depth_margin = float(as_number(member(member(ext, "depthTest", where_, E), "margin", where_, E + ".depthTest"),
                                        where_, E + ".depthTest.margin"));
  }

  // The Gaussians: one Draco point cloud, or importance tiers (one each) of which a
  // prefix is read (UnpackOptions::max_gaussians); decoded back to the trainer's parameters.
  void gaussians() {
    const Json& jg = member(*ext_, "gaussians", where_, E);
    const std::string G = E + ".gaussians";
    N_ = rd_.integer(jg, "count", G, 0, kMaxCount);
    info_.scale_encoding = as_string(member(jg, "scaleEncoding", where_, G), where_, G + ".scaleEncoding");
    info_.rotation_encoding = as_string(member(jg, "rotationEncoding", where_, G), where_, G + ".rotationEncoding");
    if (info_.scale_encoding != "log" && info_.scale_encoding != "linear") {
      fail(where_, G + ".scaleEncoding: unknown '" + info_.scale_encoding + "'");
    }
    if (info_.rotation_encoding != "wxyz" && info_.rotation_encoding != "smallest3") {
      fail(where_, G + ".rotationEncoding: unknown '" + info_.rotation_encoding + "'");
    }
    if (const Json* o = find_member(jg, "order")) {
      info_.gaussian_order = as_string(*o, where_, G + ".order");
      if (info_.gaussian_order != "original" && info_.gaussian_order != "face") fail(where_, G + ".order: unknown '" + info_.gaussian_order + "'");
    }
    if (const Json* qb = find_member(jg, "quantizationBits")) {
      if (qb->is_object())
        for (auto& [k, v] : qb->items()) info_.gaussian_bits[k] = int(as_int(v, where_, G + ".quantizationBits." + k, 0, 30));
    }
    if (const Json* fo = find_member(jg, "faceOrder")) {
      const std::string order = as_string(*fo, where_, G + ".faceOrder");
      if (order != "file" && order != "canonical") fail(where_, G + ".faceOrder: unknown '" + order + "'");
      if (order == "canonical" && info_.version < 3) fail(where_, G + ".faceOrder: 'canonical' is not in version " + std::to_string(info_.version));
      faces_in_file_order_ = order == "file";
    } else if (info_.version >= 3) {
      fail(where_, G + ".faceOrder: missing");
    }
    // Faces in the file's order hold only while the mesh is the one haha wrote (body.draco
    // names its stream and checksum); a tool that rewrote it may have reordered them.
    if (faces_in_file_order_ && (!jd_ || rewritten_)) {
      fail(where_, G + ".faceOrder: the Gaussians name faces in the file's order, but the mesh was rewritten (no " + B +
                       ".draco); repack without --lossless for files that tools may rewrite");
    }
    info_.gaussian_face_order = faces_in_file_order_ ? "file" : "canonical";
    if (!faces_in_file_order_) canonical_face_order();
    const Json* tiers = find_member(jg, "tiers");
    if (N_ == 0) {  // no point cloud: every Gaussian was filtered away
      if (find_member(jg, "bufferView") || tiers) fail(where_, G + ": a point cloud for zero Gaussians");
      return;
    }
    gids_ = &member(jg, "attributes", where_, G);
    struct Stream {
      glb::ByteSpan bytes;
      int64_t count;
    };
    std::vector<Stream> streams;
    if (!tiers) {
      streams.push_back({rd_.view(jg, "bufferView", "crc32", G), N_});
      info_.sizes.gaussians = streams[0].bytes.size;
    } else {
      if (info_.version < 2) fail(where_, G + ".tiers: not in version 1");
      if (find_member(jg, "bufferView")) fail(where_, G + ": both a bufferView and tiers");
      if (!tiers->is_array() || tiers->empty() || tiers->size() > size_t(kMaxLodTiers)) {
        fail(where_, G + ".tiers: must be an array of 1 to " + std::to_string(kMaxLodTiers) + " tiers");
      }
      int64_t total = 0, taken = 0;
      for (size_t t = 0; t < tiers->size(); ++t) {
        const Json& tier = (*tiers)[t];
        const std::string T = G + ".tiers[" + std::to_string(t) + "]";
        const int64_t count = rd_.integer(tier, "count", T, 1, kMaxCount);
        total += count;
        info_.lod_counts.push_back(int(count));
        info_.lod_psnr.push_back(find_member(tier, "psnr") ? as_number(member(tier, "psnr", where_, T), where_, T + ".psnr") : INFINITY);
        const glb::ByteSpan bytes = glb::buffer_view(g_, int(rd_.integer(tier, "bufferView", T, 0, kMaxCount)), where_);
        info_.sizes.gaussians += bytes.size;
        // A prefix of whole tiers within the limit; the first tier always.
        const bool take = opt_.max_gaussians <= 0 || taken == 0 || taken + count <= opt_.max_gaussians;
        if (take && int64_t(streams.size()) == int64_t(t)) {
          streams.push_back({rd_.view(tier, "bufferView", "crc32", T), count});
          taken += count;
        }
      }
      if (total != N_) fail(where_, G + ".tiers: hold " + std::to_string(total) + " Gaussians, the file says " + std::to_string(N_));
    }
    std::vector<int64_t> corners;
    for (const Stream& st : streams) decode_gaussians(st.bytes, st.count, corners);
    N_ = a_.gaussians.size();  // the Gaussians read (a prefix of tiers may be fewer)
    if (face_corner_stored()) face_corners(corners);
    BoundGaussians& bg = a_.gaussians;
    if (info_.scale_encoding == "log") {
      for (float& x : bg.scale) {
        if (!std::isfinite(x)) fail(where_, "gaussians: non-finite log scale");
        x = std::exp(x);
      }
    }
    if (info_.gaussian_bits["ROTATION"] > 0) {  // quantized: back to unit length
      for (int64_t i = 0; i < N_; ++i) {
        float* q = &bg.rotation[size_t(i) * 4];
        const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
        if (!(n > 1e-6)) fail(where_, "gaussians: zero rotation at Gaussian " + std::to_string(i));
        for (int k = 0; k < 4; ++k) q[k] = float(q[k] / n);
      }
    }
    if (info_.gaussian_bits["OPACITY"] > 0)  // quantization can step just outside [0, 1]
      for (float& o : bg.opacity) o = std::isfinite(o) ? std::min(1.0f, std::max(0.0f, o)) : o;
  }

  // In the face order the Gaussians name (the file's, or canonical: sorted by smallest
  // vertex) a garment's faces come after the body's, where BodyModel::garment_first_face says.
  void garment_faces_last() {
    const BodyModel& body = a_.body;
    if (!body.has_garment()) return;
    for (size_t c = 0; c < body.faces.size(); ++c) {
      if ((body.faces[c] >= body.garment_first_vert) != (int64_t(c / 3) >= body.garment_first_face)) {
        fail(where_, B + ".garment: face " + std::to_string(c / 3) + " of the Gaussians' face order is not where the garment's faces are");
      }
    }
  }

  // Appends one point cloud of `count` Gaussians (scales still as stored) to the avatar's,
  // and its FACE_CORNER values (edgebreaker meshes) to `corners`.
  void decode_gaussians(const glb::ByteSpan& bytes, int64_t count, std::vector<int64_t>& corners) {
    const std::string GA = E + ".gaussians.attributes";
    const Json& gids = *gids_;
    dracoio::Decoded gdec(bytes.data, bytes.size, false, where_, "gaussians", count);
    if (gdec.num_points() != count) {
      fail(where_, "gaussians: Draco stream has " + std::to_string(gdec.num_points()) + " points, the file says " + std::to_string(count));
    }
    BoundGaussians& bg = a_.gaussians;
    const size_t first = bg.face.size();
    for (int64_t f : gdec.ints(draco_id(gids, "FACE", GA), 1, "FACE")) {
      if (f < 0 || f >= F_) {
        fail(where_, "gaussians: Gaussian " + std::to_string(bg.face.size()) + " refers to face " + std::to_string(f) +
                         ", out of range [0, " + std::to_string(F_) + ")");
      }
      bg.face.push_back(int32_t(f));
    }
    if (face_corner_stored()) {
      const std::vector<int64_t> c = gdec.ints(draco_id(gids, "FACE_CORNER", GA), 1, "FACE_CORNER");
      corners.insert(corners.end(), c.begin(), c.end());
    }
    auto append = [](std::vector<float>& to, const std::vector<float>& from) { to.insert(to.end(), from.begin(), from.end()); };
    append(bg.offset, gdec.floats(draco_id(gids, "OFFSET", GA), 3, "OFFSET"));
    if (info_.rotation_encoding == "wxyz") {
      append(bg.rotation, gdec.floats(draco_id(gids, "ROTATION", GA), 3 + 1, "ROTATION"));
    } else {
      const std::vector<float> r3 = gdec.floats(draco_id(gids, "ROTATION", GA), 3, "ROTATION");
      const std::vector<int64_t> m = gdec.ints(draco_id(gids, "ROTATION_LARGEST", GA), 1, "ROTATION_LARGEST");
      bg.rotation.resize((first + size_t(count)) * 4);
      for (int64_t i = 0; i < count; ++i) {
        const int64_t l = m[size_t(i)];
        if (l < 0 || l > 3) fail(where_, "gaussians: ROTATION_LARGEST " + std::to_string(l) + " out of range at Gaussian " + std::to_string(first + size_t(i)));
        float* q = &bg.rotation[(first + size_t(i)) * 4];
        double s2 = 0;
        for (int k = 0, o = 0; k < 4; ++k) {
          if (k == l) continue;
          q[k] = r3[size_t(i) * 3 + o++];
          s2 += double(q[k]) * q[k];
        }
        q[l] = float(std::sqrt(std::max(0.0, 1.0 - s2)));
      }
    }
    append(bg.scale, gdec.floats(draco_id(gids, "SCALE", GA), 3, "SCALE"));
    append(bg.color, gdec.floats(draco_id(gids, "COLOR", GA), 3, "COLOR"));
    append(bg.opacity, gdec.floats(draco_id(gids, "OPACITY", GA), 1, "OPACITY"));
  }

  // Whether each Gaussian carries FACE_CORNER: its face's corners may be rotated.
  bool face_corner_stored() const { return !faces_in_file_order_ || edgebreaker_; }

  // The faces (and their UV corners) in the canonical order the Gaussians name
  // (format/canonical_faces.h): each rotated to its smallest triple, sorted.
  void canonical_face_order() {
    BodyModel& body = a_.body;
    const CanonicalFaces c = canonical_faces(body.faces.data(), body.num_faces);
    std::vector<int32_t> faces(body.faces.size()), ft(body.ft.size());
    for (size_t k = 0; k < c.order.size(); ++k) {
      const size_t f = size_t(c.order[k]), r = c.rotation[f];
      for (size_t i = 0; i < 3; ++i) {
        faces[k * 3 + i] = body.faces[f * 3 + (r + i) % 3];
        ft[k * 3 + i] = body.ft[f * 3 + (r + i) % 3];
      }
    }
    body.faces = std::move(faces);
    body.ft = std::move(ft);
  }

  // The faces' corners may be rotated (edgebreaker, canonical order): turn each face that carries Gaussians
  // back so its corner 0 is the body's (face frames depend on the corner order).
  void face_corners(const std::vector<int64_t>& corner) {
    std::vector<int8_t> done(size_t(F_), -1);
    BodyModel& body = a_.body;
    for (int64_t i = 0; i < N_; ++i) {
      const int64_t r = corner[size_t(i)];
      const size_t f = size_t(a_.gaussians.face[size_t(i)]);
      if (r < 0 || r > 2) fail(where_, "gaussians: FACE_CORNER " + std::to_string(r) + " out of range at Gaussian " + std::to_string(i));
      if (done[f] >= 0) {
        if (done[f] != r) fail(where_, "gaussians: Gaussians on face " + std::to_string(f) + " disagree on FACE_CORNER");
        continue;
      }
      done[f] = int8_t(r);
      std::rotate(body.faces.begin() + long(f * 3), body.faces.begin() + long(f * 3 + size_t(r)), body.faces.begin() + long(f * 3 + 3));
      std::rotate(body.ft.begin() + long(f * 3), body.ft.begin() + long(f * 3 + size_t(r)), body.ft.begin() + long(f * 3 + 3));
    }
  }

  // The texture image (its bytes kept as stored), or the exact float32 copy of lossless packs.
  void texture() {
    const Json& jt = member(*ext_, "texture", where_, E);
    const int64_t image_index = rd_.integer(jt, "image", E + ".texture", 0, kMaxCount);
    const Json& image = element(root_, "images", image_index, where_);
    info_.texture_mime = as_string(member(image, "mimeType", where_, "images[" + std::to_string(image_index) + "]"), where_, "image.mimeType");
    const Json image_ref = {{"bufferView", member(image, "bufferView", where_, "images[" + std::to_string(image_index) + "]")},
                            {"crc32", member(jt, "crc32", where_, E + ".texture")}};
    const glb::ByteSpan img = rd_.view(image_ref, "bufferView", "crc32", E + ".texture");
    info_.sizes.texture = img.size;
    out_.texture_image.assign(img.data, img.data + img.size);
    if (const Json* ex = find_member(jt, "exact")) {
      const std::string what = E + ".texture.exact";
      const int64_t w = rd_.integer(*ex, "width", what, 1, 16384), h = rd_.integer(*ex, "height", what, 1, 16384);
      const glb::ByteSpan s = rd_.view(*ex, "bufferView", "crc32", what);
      if (s.size != size_t(w * h * 3 * 4)) fail(where_, what + ": wrong byte length for " + std::to_string(w) + " x " + std::to_string(h) + " x 3 float32");
      a_.texture.width = int(w);
      a_.texture.height = int(h);
      a_.texture.rgb.resize(size_t(w * h * 3));
      std::memcpy(a_.texture.rgb.data(), s.data, s.size);
      info_.texture_exact = true;
      info_.sizes.texture_exact = s.size;
      const Texture t = decode_texture(img.data, img.size, info_.texture_mime, where_);  // still must decode
      info_.texture_width = t.width;
      info_.texture_height = t.height;
    } else {
      a_.texture = decode_texture(img.data, img.size, info_.texture_mime, where_);
      info_.texture_width = a_.texture.width;
      info_.texture_height = a_.texture.height;
    }
  }

  // The optional KHR_gaussian_splatting primitive: only its size is reported.
  void splats() {
    const Json* sp = find_member(*ext_, "splats");
    if (!sp) return;
    info_.splats = true;
    const Json& smesh = element(root_, "meshes", rd_.integer(*sp, "mesh", E + ".splats", 0, kMaxCount), where_);
    const Json& sprims = member(smesh, "primitives", where_, "splat mesh");
    if (sprims.is_array() && !sprims.empty()) {
      if (const Json* at = find_member(sprims[0], "attributes"); at && at->is_object()) {
        for (auto& [k, v] : at->items()) {
          const Json& acc = element(root_, "accessors", as_int(v, where_, "splat attribute " + k, 0, kMaxCount), where_);
          if (const Json* bv = find_member(acc, "bufferView"))
            info_.sizes.splats += glb::buffer_view(g_, int(as_int(*bv, where_, "accessor.bufferView", 0, kMaxCount)), where_).size;
        }
      }
    }
  }

  void summary() {
    info_.body_vertex_count = int(V_);
    info_.sizes.num_gaussians = int(N_);
    info_.sizes.num_vertices = Vg_;
    info_.sizes.num_faces = int(F_);
    info_.sizes.skin_sets = int(skin_sets_);
    int most = 0;
    for (int64_t v = 0; v < V_; ++v) {
      int c = 0;
      for (int j = 0; j < kNumJoints; ++j) c += a_.body.weights[size_t(v) * kNumJoints + size_t(j)] != 0.0f;
      most = std::max(most, c);
    }
    info_.sizes.max_influences = most;
  }

  const std::string E = kAvatarExtension;
  const std::string B = E + ".body";
  const glb::Glb& g_;
  const Json& root_;
  const std::string& where_;
  Reader rd_;
  const UnpackOptions& opt_;
  UnpackedAvatar& out_;
  AvatarFileInfo& info_;
  Avatar& a_;
  const Json* ext_ = nullptr;     // the HAHA_gaussian_avatar object
  const Json* jb_ = nullptr;      // its "body"
  const Json* pattrs_ = nullptr;  // the body primitive's attributes
  const Json* jd_ = nullptr;      // body.draco (absent: a plain mesh, or a mesh rewritten by a tool)
  const Json* jg_ = nullptr;      // body.garment (absent: no garment)
  const Json* jrec_ = nullptr;    // the Draco record of the primitive being read (body.draco, body.garment.draco)
  bool rewritten_ = false;        // a Draco primitive without its record: re-encoded by a tool
  int64_t expected_faces_ = 0;    // triangles of the primitive being read
  int garment_first_uv_ = 0;      // glTF vertices of the body, before the garment's
  float garment_chart_ = 0;
  MeshArrays m_;
  const Json* skin_ = nullptr;
  const Json* gids_ = nullptr;    // the Gaussians' Draco attribute ids
  std::string P_;                 // JSON path of the body primitive
  int64_t V_ = 0, F_ = 0, N_ = 0, skin_sets_ = 0;
  int Vg_ = 0;
  bool edgebreaker_ = false;  // faces in the encoder's order, corners rotated
  bool faces_in_file_order_ = true;  // gaussians.faceOrder "file" (else "canonical")
};

UnpackedAvatar unpack_impl(const uint8_t* data, size_t size, const std::string& where, const UnpackOptions& opt) {
  const glb::Glb g = glb::parse_glb(data, size, where);
  UnpackedAvatar out;
  AvatarReader(g, where, opt, out).read();
  out.animations = read_animations(g, where);
  for (const AvatarAnimation& a : out.animations) out.info.sizes.animations += a.bytes;
  out.info.sizes.total = size;
  return out;
}

}  // namespace

UnpackedAvatar unpack_avatar(const uint8_t* data, size_t size, const std::string& where, const UnpackOptions& options) {
  try {
    return unpack_impl(data, size, where, options);
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    fail(where, "corrupt file: a size field asks for more memory than is available");
  } catch (const std::exception& e) {
    fail(where, std::string("corrupt file: ") + e.what());
  }
}

UnpackedAvatar read_avatar_file(const std::string& path, const UnpackOptions& options) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) fail(path, "read error");
  return unpack_avatar(bytes.data(), bytes.size(), path, options);
}

std::string texture_file_extension(const std::string& mime) {
  if (mime == "image/png") return "png";
  if (mime == "image/jpeg") return "jpg";
  if (mime == "image/webp") return "webp";
  return "bin";
}

}  // namespace haha
