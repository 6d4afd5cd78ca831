#include "render/render_mesh.h"

#include <algorithm>
#include <string>

#include "core/error.h"

namespace haha {

namespace {

void check_uv(const MeshRenderInput& in, const char* fn) {
  if (in.num_faces > 0 && (!in.uv_faces || !in.uv)) fail(fn, "null UV buffer");
  for (int64_t i = 0; i < int64_t(in.num_faces) * 3; ++i)
    if (in.uv_faces[i] < 0 || in.uv_faces[i] >= in.num_uv)
      fail(fn, "uv face " + std::to_string(i / 3) + " has UV index " + std::to_string(in.uv_faces[i]) +
                   " outside [0, " + std::to_string(in.num_uv) + ")");
  const TextureView& t = in.texture;
  if (t.width <= 0 || t.height <= 0 || t.channels <= 0 || !t.data) fail(fn, "texture is empty");
}

}  // namespace

void render_mesh(const Camera& cam, const MeshRenderInput& in, MeshRender& out) {
  check_uv(in, "render_mesh");
  rasterize_mesh(cam, MeshView{in.verts, in.num_verts, in.faces, in.num_faces, in.coverage}, out.raster);
  const int P = out.raster.num_pixels();
  const int C = in.texture.channels;
  out.uv.resize(size_t(P) * 2);
  out.color.resize(size_t(P) * C);
  interpolate(P, out.raster.tri.data(), out.raster.bary.data(), in.uv_faces, in.uv, 2, out.uv.data());
  sample_texture(in.texture, P, out.raster.tri.data(), out.uv.data(), out.color.data());
}

void render_mesh_backward(const Camera& cam, const MeshRenderInput& in, MeshRender& fwd, const float* grad_color,
                          const float* grad_depth, float* grad_texture, float* grad_verts) {
  check_uv(in, "render_mesh_backward");
  const int P = fwd.raster.num_pixels();
  if (P != cam.width * cam.height) fail("render_mesh_backward", "forward buffers do not match the camera size");
  const int32_t* tri = fwd.raster.tri.data();
  if (!grad_verts) {
    if (grad_texture && grad_color)
      sample_texture_backward(in.texture, P, tri, fwd.uv.data(), grad_color, grad_texture, nullptr);
    return;
  }
  fwd.grad_bary_.resize(size_t(P) * 3);
  if (grad_color) {
    fwd.grad_uv_.resize(size_t(P) * 2);
    sample_texture_backward(in.texture, P, tri, fwd.uv.data(), grad_color, grad_texture, fwd.grad_uv_.data());
    interpolate_backward(P, in.num_uv, tri, fwd.raster.bary.data(), in.uv_faces, in.uv, 2, fwd.grad_uv_.data(),
                         nullptr, fwd.grad_bary_.data());
  } else {
    std::fill(fwd.grad_bary_.begin(), fwd.grad_bary_.end(), 0.0f);  // depth-only gradient
  }
  mesh_barycentrics_backward(cam, MeshView{in.verts, in.num_verts, in.faces, in.num_faces}, tri,
                             fwd.grad_bary_.data(), grad_depth, grad_verts);
}

}  // namespace haha
