#include "format/avatar_npz.h"

#include <cmath>

#include "core/error.h"
#include "format/avatar_validate.h"
#include "io/npy.h"

namespace haha {

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
  validate_subject(a, path);
  validate_gaussians(g, -1, path);
  return a;
}

void attach_body(Avatar& a, BodyModel body, const std::string& path) {
  std::vector<float> d = std::move(a.body.rest_offsets);
  if (!d.empty() && d.size() != size_t(body.num_verts) * 3)
    fail(path, "rest_offsets: " + std::to_string(d.size() / 3) + " vertices, the body model has " +
                   std::to_string(body.num_verts));
  a.body = std::move(body);
  a.body.rest_offsets = std::move(d);
}

}  // namespace haha
