#include "format/avatar_npz.h"

#include <cmath>

#include "core/error.h"
#include "format/avatar_validate.h"
#include "io/npy.h"

namespace haha {

namespace {

// The garment's arrays under garment_* keys (avatar.npz, the run's garment.npz).
void put_garment(Npz& z, const Garment& gm) {
  const int64_t G = gm.num_verts(), F = gm.num_faces();
  z.set("garment_vertices", NpyArray::from(gm.verts, {G, 3}));
  z.set("garment_faces", NpyArray::from(gm.faces, {F, 3}));
  z.set("garment_weights", NpyArray::from(gm.weights, {G, int64_t(kNumJoints)}));
  z.set("garment_uv", NpyArray::from(gm.vt, {int64_t(gm.vt.size() / 2), 2}));
  z.set("garment_uv_faces", NpyArray::from(gm.ft, {F, 3}));
  z.set("garment_chart", NpyArray::from(std::vector<float>{gm.chart}, {1}));
}

Garment get_garment(const Npz& z, const std::string& path) {
  Garment gm;
  gm.verts = z.get("garment_vertices", {-1, 3}).as_float();
  const int64_t G = int64_t(gm.verts.size() / 3);
  gm.faces = z.get("garment_faces", {-1, 3}).as_int32();
  gm.weights = z.get("garment_weights", {G, int64_t(kNumJoints)}).as_float();
  gm.vt = z.get("garment_uv", {-1, 2}).as_float();
  gm.ft = z.get("garment_uv_faces", {int64_t(gm.faces.size() / 3), 3}).as_int32();
  gm.chart = z.get("garment_chart", {1}).as_float()[0];
  validate_garment(gm, path.c_str());
  return gm;
}

}  // namespace

void save_garment_npz(const Garment& g, const std::string& path) {
  validate_garment(g, path.c_str());
  Npz z(path);
  put_garment(z, g);
  z.write(path);
}

Garment load_garment_npz(const std::string& path) { return get_garment(Npz::read(path), path); }

void save_avatar_npz(const Avatar& a, const std::string& path) {
  validate_subject(a, path);
  validate_gaussians(a.gaussians, -1, path);
  const BoundGaussians& g = a.gaussians;
  const int64_t n = g.size();
  Npz z(path);
  z.set("format_version", NpyArray::from(std::vector<int32_t>{kAvatarNpzVersion}, {1}));
  z.set("betas", NpyArray::from(a.betas, {int64_t(a.betas.size())}));
  z.set("expression", NpyArray::from(a.expression, {int64_t(a.expression.size())}));
  z.set("face_scale_divisor", NpyArray::from(std::vector<float>{a.face_scale_divisor}, {1}));
  z.set("depth_margin", NpyArray::from(std::vector<float>{a.depth_margin}, {1}));
  z.set("texture", NpyArray::from(a.texture.rgb, {a.texture.height, a.texture.width, 3}));
  z.set("gaussian_face", NpyArray::from(g.face, {n}));
  z.set("gaussian_offset", NpyArray::from(g.offset, {n, 3}));
  z.set("gaussian_rotation", NpyArray::from(g.rotation, {n, 4}));
  z.set("gaussian_scale", NpyArray::from(g.scale, {n, 3}));
  z.set("gaussian_color", NpyArray::from(g.color, {n, 3}));
  z.set("gaussian_opacity", NpyArray::from(g.opacity, {n}));
  const std::vector<float>& d = a.body.rest_offsets;
  if (!d.empty()) z.set("rest_offsets", NpyArray::from(d, {int64_t(d.size() / 3), 3}));
  if (!a.mesh_coverage.empty()) z.set("mesh_coverage", NpyArray::from(a.mesh_coverage, {int64_t(a.mesh_coverage.size())}));
  const Garment gm = a.body.has_garment() ? garment_of(a.body) : a.garment;
  if (!gm.empty()) put_garment(z, gm);
  z.write(path);
}

Avatar load_avatar_npz(const std::string& path) {
  const Npz z = Npz::read(path);
  const std::vector<int32_t> version = z.get("format_version", {1}).as_int32();
  if (version[0] != kAvatarNpzVersion) {
    fail(path, "format_version: " + std::to_string(version[0]) + " is not supported (this build reads " +
                   std::to_string(kAvatarNpzVersion) + ")");
  }
  Avatar a;
  a.betas = z.get("betas", {-1}).as_float();
  a.expression = z.get("expression", {-1}).as_float();
  a.face_scale_divisor = z.get("face_scale_divisor", {1}).as_float()[0];
  if (z.has("depth_margin")) a.depth_margin = z.get("depth_margin", {1}).as_float()[0];  // absent: exact test
  const NpyArray& tex = z.get("texture", {-1, -1, 3});
  a.texture.height = int(tex.shape[0]);
  a.texture.width = int(tex.shape[1]);
  a.texture.rgb = tex.as_float();
  const NpyArray& face = z.get("gaussian_face", {-1});
  const int64_t n = face.shape[0];
  BoundGaussians& g = a.gaussians;
  g.face = face.as_int32();
  g.offset = z.get("gaussian_offset", {n, 3}).as_float();
  g.rotation = z.get("gaussian_rotation", {n, 4}).as_float();
  g.scale = z.get("gaussian_scale", {n, 3}).as_float();
  g.color = z.get("gaussian_color", {n, 3}).as_float();
  g.opacity = z.get("gaussian_opacity", {n}).as_float();
  if (z.has("rest_offsets")) {
    a.body.rest_offsets = z.get("rest_offsets", {-1, 3}).as_float();
    for (float x : a.body.rest_offsets)
      if (!std::isfinite(x)) fail(path, "rest_offsets: non-finite value");
  }
  if (z.has("garment_vertices")) a.garment = get_garment(z, path);
  if (z.has("mesh_coverage")) a.mesh_coverage = z.get("mesh_coverage", {-1}).as_float();
  validate_subject(a, path);
  validate_gaussians(g, -1, path);
  return a;
}

void attach_body(Avatar& a, BodyModel body, const std::string& path) {
  if (!a.garment.empty()) {  // the garment's vertices follow the body's: the offsets cover both
    if (!body.has_garment())
      body = append_garment(body, a.garment);
    else if (garment_of(body).verts != a.garment.verts)  // an avatar's own body (eval's stage-1 avatar)
      fail(path, "garment: the body has another garment than the avatar's");
    a.garment = Garment();
  }
  std::vector<float> d = std::move(a.body.rest_offsets);
  if (!d.empty() && d.size() != size_t(body.num_verts) * 3)
    fail(path, "rest_offsets: " + std::to_string(d.size() / 3) + " vertices, the body model has " +
                   std::to_string(body.num_verts));
  if (!a.mesh_coverage.empty() && a.mesh_coverage.size() != size_t(body.num_verts))
    fail(path, "mesh_coverage: " + std::to_string(a.mesh_coverage.size()) + " vertices, the body model has " +
                   std::to_string(body.num_verts));
  a.body = std::move(body);
  a.body.rest_offsets = std::move(d);
}

}  // namespace haha
