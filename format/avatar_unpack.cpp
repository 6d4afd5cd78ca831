#include "format/avatar_unpack.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <new>
#include <set>

#include "core/error.h"
#include "format/avatar_validate.h"
#include "format/draco_io.h"
#include "format/glb.h"
#include "format/image_codec.h"

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

UnpackedAvatar unpack_impl(const uint8_t* data, size_t size, const std::string& where, const UnpackOptions& opt) {
  const glb::Glb g = glb::parse_glb(data, size, where);
  const Json& root = g.json;
  Reader rd(g, where, opt);
  UnpackedAvatar out;
  AvatarFileInfo& info = out.info;
  info.sizes.total = size;
  info.sizes.json = g.json_chunk_bytes;
  info.extensions_used = string_list(root, "extensionsUsed", where);
  info.extensions_required = string_list(root, "extensionsRequired", where);
  for (const std::string& e : info.extensions_required) {
    if (!kSupportedRequired.count(e)) fail(where, "requires glTF extension " + e + ", which this loader does not support");
  }
  const Json* exts = find_member(root, "extensions");
  const Json* ext = exts ? find_member(*exts, kAvatarExtension) : nullptr;
  if (!ext) fail(where, std::string("not a HAHA avatar: the glTF has no ") + kAvatarExtension + " extension");
  const std::string E = kAvatarExtension;
  if (!ext->is_object()) fail(where, E + ": not a JSON object");
  const Json& ver = member(*ext, "version", where, E);
  if (!ver.is_number_integer() || ver.get<int64_t>() != kAvatarFormatVersion) {
    fail(where, E + ": unsupported version " + ver.dump() + " (this loader reads version " +
                    std::to_string(kAvatarFormatVersion) + ")");
  }
  info.version = kAvatarFormatVersion;

  // ---- body mesh ----
  const Json& jb = member(*ext, "body", where, E);
  const std::string B = E + ".body";
  const int64_t mesh_index = rd.integer(jb, "mesh", B, 0, kMaxCount);
  const int64_t V = rd.integer(jb, "vertexCount", B, 1, kMaxCount);
  const int64_t F = rd.integer(jb, "faceCount", B, 1, kMaxCount);
  const int64_t skin_sets = rd.integer(jb, "skinSets", B, 1, 14);
  const int64_t skin_index = rd.integer(jb, "skin", B, 0, kMaxCount);
  const Json& mesh = element(root, "meshes", mesh_index, where);
  const Json& prims = member(mesh, "primitives", where, "meshes[" + std::to_string(mesh_index) + "]");
  if (!prims.is_array() || prims.empty()) fail(where, "body mesh: no primitives");
  const Json& prim = prims[0];
  const std::string P = "meshes[" + std::to_string(mesh_index) + "].primitives[0]";
  const Json* pext = find_member(prim, "extensions");
  const Json* kdraco = pext ? find_member(*pext, "KHR_draco_mesh_compression") : nullptr;
  if (!kdraco) fail(where, P + ": not Draco-compressed (KHR_draco_mesh_compression missing)");
  const Json& jd = member(jb, "draco", where, B);
  if (rd.integer(*kdraco, "bufferView", P + ".KHR_draco_mesh_compression", 0, kMaxCount) !=
      rd.integer(jd, "bufferView", B + ".draco", 0, kMaxCount)) {
    fail(where, B + ".draco: bufferView differs from the primitive's Draco stream");
  }
  const glb::ByteSpan mesh_bytes = rd.view(jd, "bufferView", "crc32", B + ".draco");
  info.sizes.mesh = mesh_bytes.size;
  const Json& pattrs = member(prim, "attributes", where, P);
  const Json& pos_acc = element(root, "accessors", as_int(member(pattrs, "POSITION", where, P + ".attributes"), where,
                                                          P + ".attributes.POSITION", 0, kMaxCount), where);
  const int64_t gltf_verts = as_int(member(pos_acc, "count", where, "POSITION accessor"), where, "POSITION accessor.count", 1, kMaxCount);
  dracoio::Decoded mesh_dec(mesh_bytes.data, mesh_bytes.size, true, where, "body mesh", gltf_verts, F);
  const int Vg = mesh_dec.num_points();
  if (mesh_dec.num_faces() != F) {
    fail(where, "body mesh: Draco stream has " + std::to_string(mesh_dec.num_faces()) + " faces, the file says " + std::to_string(F));
  }
  if (Vg < V) fail(where, "body mesh: fewer glTF vertices than body vertices");
  const Json& dattrs = member(*kdraco, "attributes", where, P + ".KHR_draco_mesh_compression");
  auto draco_id = [&](const Json& map, const std::string& name, const std::string& what) {
    return int(as_int(member(map, name.c_str(), where, what), where, what + "." + name, 0, 1 << 20));
  };
  const std::vector<float> pos = mesh_dec.floats(draco_id(dattrs, "POSITION", P), 3, "POSITION");
  const std::vector<float> uvg = mesh_dec.floats(draco_id(dattrs, "TEXCOORD_0", P), 2, "TEXCOORD_0");
  const Json& mpriv = member(jd, "attributes", where, B + ".draco");
  const std::vector<int64_t> source = mesh_dec.ints(draco_id(mpriv, "BODY_VERTEX", B + ".draco.attributes"), 1, "BODY_VERTEX");
  std::vector<float> uv_src;
  if (find_member(mpriv, "TEXCOORD_SOURCE")) {
    uv_src = mesh_dec.floats(draco_id(mpriv, "TEXCOORD_SOURCE", B + ".draco.attributes"), 2, "TEXCOORD_SOURCE");
  }
  if (const Json* qb = find_member(jd, "quantizationBits")) {
    if (qb->is_object())
      for (auto& [k, v] : qb->items()) info.mesh_bits[k] = int(as_int(v, where, B + ".draco.quantizationBits." + k, 0, 30));
  }

  Avatar& a = out.avatar;
  BodyModel& body = a.body;
  body.source = where;
  body.num_verts = int(V);
  body.num_faces = int(F);
  body.v_template.assign(size_t(V) * 3, 0.0f);
  std::vector<char> seen(size_t(V), 0);
  for (int gi = 0; gi < Vg; ++gi) {
    const int64_t s = source[size_t(gi)];
    if (s < 0 || s >= V) fail(where, "body mesh: BODY_VERTEX " + std::to_string(s) + " out of range [0, " + std::to_string(V) + ")");
    if (!seen[size_t(s)]) {
      seen[size_t(s)] = 1;
      for (int k = 0; k < 3; ++k) body.v_template[size_t(s) * 3 + k] = pos[size_t(gi) * 3 + k];
    }
  }
  for (int64_t v = 0; v < V; ++v)
    if (!seen[size_t(v)]) fail(where, "body mesh: body vertex " + std::to_string(v) + " has no glTF vertex");
  const std::vector<int32_t> gfaces = mesh_dec.faces();
  body.faces.resize(gfaces.size());
  for (size_t c = 0; c < gfaces.size(); ++c) body.faces[c] = int32_t(source[size_t(gfaces[c])]);
  body.ft = gfaces;
  body.vt.resize(size_t(Vg) * 2);
  for (int gi = 0; gi < Vg; ++gi) {
    if (!uv_src.empty()) {
      body.vt[size_t(gi) * 2] = uv_src[size_t(gi) * 2];
      body.vt[size_t(gi) * 2 + 1] = uv_src[size_t(gi) * 2 + 1];
    } else {
      body.vt[size_t(gi) * 2] = uvg[size_t(gi) * 2];
      body.vt[size_t(gi) * 2 + 1] = 1.0f - uvg[size_t(gi) * 2 + 1];  // back to the body model's v-up UVs
    }
  }
  // Skinning weights: scatter every JOINTS_n/WEIGHTS_n set back to the dense (V, 55) array.
  body.weights.assign(size_t(V) * kNumJoints, 0.0f);
  const bool quantized_weights = info.mesh_bits.count("WEIGHTS") && info.mesh_bits["WEIGHTS"] > 0;
  std::vector<char> done(size_t(V), 0);
  std::vector<std::vector<int64_t>> js(static_cast<size_t>(skin_sets));
  std::vector<std::vector<float>> ws(static_cast<size_t>(skin_sets));
  for (int64_t s = 0; s < skin_sets; ++s) {
    const std::string jn = "JOINTS_" + std::to_string(s), wn = "WEIGHTS_" + std::to_string(s);
    js[size_t(s)] = mesh_dec.ints(draco_id(dattrs, jn, P), 4, jn);
    ws[size_t(s)] = mesh_dec.floats(draco_id(dattrs, wn, P), 4, wn);
  }
  for (int gi = 0; gi < Vg; ++gi) {
    const size_t v = size_t(source[size_t(gi)]);
    if (done[v]) continue;  // seam duplicates carry the same skin
    done[v] = 1;
    double sum = 0;
    for (int64_t s = 0; s < skin_sets; ++s)
      for (int k = 0; k < 4; ++k) {
        const int64_t j = js[size_t(s)][size_t(gi) * 4 + k];
        const float w = ws[size_t(s)][size_t(gi) * 4 + k];
        if (j < 0 || j >= kNumJoints) fail(where, "body mesh: " + ("JOINTS_" + std::to_string(s)) + " index " + std::to_string(j) + " out of range");
        if (!std::isfinite(w) || w < -1e-3f) fail(where, "body mesh: invalid skinning weight at vertex " + std::to_string(v));
        if (w != 0.0f) body.weights[v * kNumJoints + size_t(j)] += w;
        sum += w;
      }
    if (quantized_weights) {  // quantization moved the sum off 1: renormalise (and drop noise)
      if (!(sum > 0)) fail(where, "body mesh: vertex " + std::to_string(v) + " has no skinning weight");
      for (int j = 0; j < kNumJoints; ++j) {
        float& w = body.weights[v * kNumJoints + size_t(j)];
        w = w > 0 ? float(w / sum) : 0.0f;
      }
    }
  }

  // ---- skeleton: parents from the node tree of the skin's joints ----
  const Json& skin = element(root, "skins", skin_index, where);
  const Json& joints = member(skin, "joints", where, "skins[" + std::to_string(skin_index) + "]");
  if (!joints.is_array() || joints.size() != size_t(kNumJoints)) fail(where, "skin: must have exactly 55 joints (SMPL-X)");
  const Json& nodes = member(root, "nodes", where, "glTF");
  if (!nodes.is_array()) fail(where, "nodes: not an array");
  std::vector<int64_t> node_parent(nodes.size(), -1);
  for (size_t n = 0; n < nodes.size(); ++n) {
    if (const Json* ch = find_member(nodes[n], "children")) {
      if (!ch->is_array()) fail(where, "nodes[" + std::to_string(n) + "].children: not an array");
      for (size_t i = 0; i < ch->size(); ++i) {
        const int64_t c = as_int((*ch)[i], where, "nodes[" + std::to_string(n) + "].children", 0, int64_t(nodes.size()) - 1);
        if (node_parent[size_t(c)] >= 0) fail(where, "nodes[" + std::to_string(c) + "]: has two parents");
        node_parent[size_t(c)] = int64_t(n);
      }
    }
  }
  std::vector<int64_t> joint_node(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) joint_node[size_t(j)] = as_int(joints[size_t(j)], where, "skin.joints", 0, int64_t(nodes.size()) - 1);
  body.parents.assign(kNumJoints, -1);
  for (int j = 0; j < kNumJoints; ++j) {
    const int64_t pn = node_parent[size_t(joint_node[size_t(j)])];
    for (int k = 0; k < kNumJoints; ++k)
      if (pn >= 0 && joint_node[size_t(k)] == pn) body.parents[size_t(j)] = k;
  }

  // ---- joint regressor ----
  const Json& jr = member(jb, "jointRegressor", where, B);
  const int64_t nnz = rd.integer(jr, "count", B + ".jointRegressor", 0, kNumJoints * V);
  const glb::ByteSpan jrb = rd.view(jr, "bufferView", "crc32", B + ".jointRegressor");
  if (jrb.size != size_t(nnz) * 12) fail(where, B + ".jointRegressor: bufferView has " + std::to_string(jrb.size) + " bytes, expected " + std::to_string(nnz * 12));
  info.joint_regressor_nonzeros = int(nnz);
  body.j_regressor.assign(size_t(kNumJoints) * V, 0.0f);
  for (int64_t i = 0; i < nnz; ++i) {
    int32_t j, v;
    float w;
    std::memcpy(&j, jrb.data + i * 4, 4);
    std::memcpy(&v, jrb.data + nnz * 4 + i * 4, 4);
    std::memcpy(&w, jrb.data + nnz * 8 + i * 4, 4);
    if (j < 0 || j >= kNumJoints || v < 0 || v >= V) fail(where, B + ".jointRegressor: entry " + std::to_string(i) + " out of range");
    body.j_regressor[size_t(j) * V + size_t(v)] = w;
  }
  if (const Json* ibm = find_member(skin, "inverseBindMatrices")) {
    const Json& acc = element(root, "accessors", as_int(*ibm, where, "skin.inverseBindMatrices", 0, kMaxCount), where);
    if (const Json* bv = find_member(acc, "bufferView")) info.sizes.skeleton += glb::buffer_view(g, int(as_int(*bv, where, "accessor.bufferView", 0, kMaxCount)), where).size;
  }
  info.sizes.skeleton += jrb.size;

  if (const Json* t = find_member(jb, "trainedWithPoseCorrectives")) {
    if (!t->is_boolean()) fail(where, B + ".trainedWithPoseCorrectives: not a boolean");
    info.trained_with_pose_correctives = t->get<bool>();
  }
  if (const Json* t = find_member(jb, "topologyCrc32")) info.topology_crc32 = uint32_t(as_int(*t, where, B + ".topologyCrc32", 0, 0xFFFFFFFFll));

  // ---- pose correctives (optional) ----
  if (const Json* pc = find_member(jb, "poseCorrectives")) {
    const std::string what = B + ".poseCorrectives";
    const std::string type = as_string(member(*pc, "componentType", where, what), where, what + ".componentType");
    const size_t count = size_t(V) * 3 * kNumPoseFeatures;
    const glb::ByteSpan s = rd.view(*pc, "bufferView", "crc32", what);
    body.posedirs.resize(count);
    if (type == "float32") {
      if (s.size != count * 4) fail(where, what + ": wrong byte length");
      std::memcpy(body.posedirs.data(), s.data, count * 4);
      info.sizes.pose_correctives = s.size;
    } else if (type == "int16") {
      if (s.size != count * 2) fail(where, what + ": wrong byte length");
      const glb::ByteSpan sc = rd.view(*pc, "scaleBufferView", "scaleCrc32", what);
      if (sc.size != size_t(kNumPoseFeatures) * 4) fail(where, what + ": wrong scale byte length");
      std::vector<float> scale(kNumPoseFeatures);
      std::memcpy(scale.data(), sc.data, sc.size);
      for (size_t i = 0; i < count; ++i) {
        int16_t q;
        std::memcpy(&q, s.data + i * 2, 2);
        body.posedirs[i] = float(q) * scale[i % kNumPoseFeatures];
      }
      info.sizes.pose_correctives = s.size + sc.size;
    } else {
      fail(where, what + ".componentType: unknown '" + type + "'");
    }
    info.pose_correctives = type;
  }

  // ---- subject ----
  const Json& subj = member(*ext, "subject", where, E);
  a.betas = glb::as_float_array(member(subj, "betas", where, E + ".subject"), where, E + ".subject.betas", 400);
  a.expression = glb::as_float_array(member(subj, "expression", where, E + ".subject"), where, E + ".subject.expression", 400);
  a.face_scale_divisor = float(as_number(member(member(*ext, "faceFrame", where, E), "scaleDivisor", where, E + ".faceFrame"),
                                         where, E + ".faceFrame.scaleDivisor"));
  if (ext->contains("depthTest"))
    a.depth_margin = float(as_number(member(member(*ext, "depthTest", where, E), "margin", where, E + ".depthTest"),
                                     where, E + ".depthTest.margin"));

  // ---- Gaussians ----
  const Json& jg = member(*ext, "gaussians", where, E);
  const std::string G = E + ".gaussians";
  const int64_t N = rd.integer(jg, "count", G, 0, kMaxCount);
  const glb::ByteSpan gbytes = rd.view(jg, "bufferView", "crc32", G);
  info.sizes.gaussians = gbytes.size;
  dracoio::Decoded gdec(gbytes.data, gbytes.size, false, where, "gaussians", N);
  if (gdec.num_points() != N) {
    fail(where, "gaussians: Draco stream has " + std::to_string(gdec.num_points()) + " points, the file says " + std::to_string(N));
  }
  const Json& gids = member(jg, "attributes", where, G);
  const std::string GA = G + ".attributes";
  if (const Json* qb = find_member(jg, "quantizationBits")) {
    if (qb->is_object())
      for (auto& [k, v] : qb->items()) info.gaussian_bits[k] = int(as_int(v, where, G + ".quantizationBits." + k, 0, 30));
  }
  info.scale_encoding = as_string(member(jg, "scaleEncoding", where, G), where, G + ".scaleEncoding");
  if (info.scale_encoding != "log" && info.scale_encoding != "linear") {
    fail(where, G + ".scaleEncoding: unknown '" + info.scale_encoding + "'");
  }
  BoundGaussians& bg = a.gaussians;
  const std::vector<int64_t> face = gdec.ints(draco_id(gids, "FACE", GA), 1, "FACE");
  bg.face.resize(size_t(N));
  for (int64_t i = 0; i < N; ++i) {
    if (face[size_t(i)] < 0 || face[size_t(i)] >= F) {
      fail(where, "gaussians: Gaussian " + std::to_string(i) + " refers to face " + std::to_string(face[size_t(i)]) +
                      ", out of range [0, " + std::to_string(F) + ")");
    }
    bg.face[size_t(i)] = int32_t(face[size_t(i)]);
  }
  bg.offset = gdec.floats(draco_id(gids, "OFFSET", GA), 3, "OFFSET");
  info.rotation_encoding = as_string(member(jg, "rotationEncoding", where, G), where, G + ".rotationEncoding");
  if (info.rotation_encoding == "wxyz") {
    bg.rotation = gdec.floats(draco_id(gids, "ROTATION", GA), 4, "ROTATION");
  } else if (info.rotation_encoding == "smallest3") {
    const std::vector<float> r3 = gdec.floats(draco_id(gids, "ROTATION", GA), 3, "ROTATION");
    const std::vector<int64_t> m = gdec.ints(draco_id(gids, "ROTATION_LARGEST", GA), 1, "ROTATION_LARGEST");
    bg.rotation.resize(size_t(N) * 4);
    for (int64_t i = 0; i < N; ++i) {
      const int64_t l = m[size_t(i)];
      if (l < 0 || l > 3) fail(where, "gaussians: ROTATION_LARGEST " + std::to_string(l) + " out of range at Gaussian " + std::to_string(i));
      float* q = &bg.rotation[size_t(i) * 4];
      double s2 = 0;
      for (int k = 0, o = 0; k < 4; ++k) {
        if (k == l) continue;
        q[k] = r3[size_t(i) * 3 + o++];
        s2 += double(q[k]) * q[k];
      }
      q[l] = float(std::sqrt(std::max(0.0, 1.0 - s2)));
    }
  } else {
    fail(where, G + ".rotationEncoding: unknown '" + info.rotation_encoding + "'");
  }
  if (const Json* o = find_member(jg, "order")) {
    info.gaussian_order = as_string(*o, where, G + ".order");
    if (info.gaussian_order != "original" && info.gaussian_order != "face") fail(where, G + ".order: unknown '" + info.gaussian_order + "'");
  }
  bg.scale = gdec.floats(draco_id(gids, "SCALE", GA), 3, "SCALE");
  bg.color = gdec.floats(draco_id(gids, "COLOR", GA), 3, "COLOR");
  bg.opacity = gdec.floats(draco_id(gids, "OPACITY", GA), 1, "OPACITY");
  if (info.scale_encoding == "log") {
    for (float& s : bg.scale) {
      if (!std::isfinite(s)) fail(where, "gaussians: non-finite log scale");
      s = std::exp(s);
    }
  }
  if (info.gaussian_bits["ROTATION"] > 0) {  // quantized: back to unit length
    for (int64_t i = 0; i < N; ++i) {
      float* q = &bg.rotation[size_t(i) * 4];
      const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
      if (!(n > 1e-6)) fail(where, "gaussians: zero rotation at Gaussian " + std::to_string(i));
      for (int k = 0; k < 4; ++k) q[k] = float(q[k] / n);
    }
  }
  if (info.gaussian_bits["OPACITY"] > 0)  // quantization can step just outside [0, 1]
    for (float& o : bg.opacity) o = std::isfinite(o) ? std::min(1.0f, std::max(0.0f, o)) : o;

  // ---- texture ----
  const Json& jt = member(*ext, "texture", where, E);
  const int64_t image_index = rd.integer(jt, "image", E + ".texture", 0, kMaxCount);
  const Json& image = element(root, "images", image_index, where);
  info.texture_mime = as_string(member(image, "mimeType", where, "images[" + std::to_string(image_index) + "]"), where, "image.mimeType");
  const Json image_ref = {{"bufferView", member(image, "bufferView", where, "images[" + std::to_string(image_index) + "]")},
                          {"crc32", member(jt, "crc32", where, E + ".texture")}};
  const glb::ByteSpan img = rd.view(image_ref, "bufferView", "crc32", E + ".texture");
  info.sizes.texture = img.size;
  out.texture_image.assign(img.data, img.data + img.size);
  if (const Json* ex = find_member(jt, "exact")) {
    const std::string what = E + ".texture.exact";
    const int64_t w = rd.integer(*ex, "width", what, 1, 16384), h = rd.integer(*ex, "height", what, 1, 16384);
    const glb::ByteSpan s = rd.view(*ex, "bufferView", "crc32", what);
    if (s.size != size_t(w * h * 3 * 4)) fail(where, what + ": wrong byte length for " + std::to_string(w) + " x " + std::to_string(h) + " x 3 float32");
    a.texture.width = int(w);
    a.texture.height = int(h);
    a.texture.rgb.resize(size_t(w * h * 3));
    std::memcpy(a.texture.rgb.data(), s.data, s.size);
    info.texture_exact = true;
    info.sizes.texture_exact = s.size;
    const Texture t = decode_texture(img.data, img.size, info.texture_mime, where);  // still must decode
    info.texture_width = t.width;
    info.texture_height = t.height;
  } else {
    a.texture = decode_texture(img.data, img.size, info.texture_mime, where);
    info.texture_width = a.texture.width;
    info.texture_height = a.texture.height;
  }

  // ---- optional KHR_gaussian_splatting primitive: only its size is reported ----
  if (const Json* sp = find_member(*ext, "splats")) {
    info.splats = true;
    const Json& smesh = element(root, "meshes", rd.integer(*sp, "mesh", E + ".splats", 0, kMaxCount), where);
    const Json& sprims = member(smesh, "primitives", where, "splat mesh");
    if (sprims.is_array() && !sprims.empty()) {
      if (const Json* at = find_member(sprims[0], "attributes"); at && at->is_object()) {
        for (auto& [k, v] : at->items()) {
          const Json& acc = element(root, "accessors", as_int(v, where, "splat attribute " + k, 0, kMaxCount), where);
          if (const Json* bv = find_member(acc, "bufferView"))
            info.sizes.splats += glb::buffer_view(g, int(as_int(*bv, where, "accessor.bufferView", 0, kMaxCount)), where).size;
        }
      }
    }
  }

  info.body_vertex_count = int(V);
  info.sizes.num_gaussians = int(N);
  info.sizes.num_vertices = Vg;
  info.sizes.num_faces = int(F);
  info.sizes.skin_sets = int(skin_sets);
  int most = 0;
  for (int64_t v = 0; v < V; ++v) {
    int c = 0;
    for (int j = 0; j < kNumJoints; ++j) c += body.weights[size_t(v) * kNumJoints + size_t(j)] != 0.0f;
    most = std::max(most, c);
  }
  info.sizes.max_influences = most;

  validate_avatar(a, where);
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
