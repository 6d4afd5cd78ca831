#include "train/avatar_render.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "body/face_frames.h"
#include "core/error.h"
#include "core/parallel.h"
#include "render/merge.h"

namespace haha {

namespace {

void check_request(const AvatarRenderRequest& req, const char* fn) {
  if (!req.camera || req.camera->width <= 0 || req.camera->height <= 0) fail(fn, "no camera");
  if ((req.gaussians || req.texture) && (!req.body || !req.verts)) fail(fn, "no posed body");
  if (req.gaussians) {
    const GaussianSetView& g = *req.gaussians;
    if (g.count < 0 || (g.count > 0 && (!g.face || !g.offset || !g.rotation || !g.scale || !g.color || !g.opacity)))
      fail(fn, "incomplete Gaussian buffers");
  }
  if (req.mesh_layer && (!req.mesh_layer->depth || !req.mesh_layer->color || !req.mesh_layer->mask))
    fail(fn, "incomplete mesh layer");
}

MeshRenderInput mesh_input(const AvatarRenderRequest& req) {
  const BodyModel& b = *req.body;
  MeshRenderInput in;
  in.verts = req.verts;
  in.num_verts = b.num_verts;
  in.faces = b.faces.data();
  in.num_faces = b.num_faces;
  in.uv = b.vt.data();
  in.num_uv = b.num_uv();
  in.uv_faces = b.ft.data();
  in.texture = *req.texture;
  return in;
}

GaussianLocalView<float> local_view(const GaussianSetView& g) {
  return {g.count, g.face, g.offset, g.rotation, g.scale};
}

GaussianInputs<float> raster_inputs(const AvatarRenderBuffers& buf, const GaussianSetView& g) {
  GaussianInputs<float> in;
  in.count = g.count;
  in.means = buf.means.data();
  in.quats = buf.quats.data();
  in.scales = buf.scales.data();
  in.opacities = g.opacity;
  in.colors = g.color;
  return in;
}

GaussianRasterSettings<float> raster_settings(const AvatarRenderRequest& req, const AvatarRenderBuffers& buf) {
  GaussianRasterSettings<float> s;
  // No background inside the rasterizer: the merge adds what lies behind exactly once.
  s.background_color = Vec3f(0, 0, 0);
  if (req.mesh_layer || req.texture) s.depth_map = req.depth_margin != 0.0f ? buf.depth_tmp.data() : buf.mesh.depth;
  return s;
}

MergeInputs merge_inputs(const AvatarRenderRequest& req, const AvatarRenderBuffers& buf) {
  MergeInputs m;
  m.num_pixels = buf.width * buf.height;
  if (req.gaussians) {
    m.color_front = buf.color_front.data();
    m.alpha = buf.alpha.data();
  }
  if (buf.mesh.mask) {
    m.mesh_color = buf.mesh.color;
    m.mesh_mask = buf.mesh.mask;
  }
  for (int c = 0; c < 3; ++c) m.background_color[c] = req.background[c];
  return m;
}

}  // namespace

void render_avatar(const AvatarRenderRequest& req, AvatarRenderBuffers& buf) {
  check_request(req, "render_avatar");
  const Camera& cam = *req.camera;
  buf.width = cam.width;
  buf.height = cam.height;
  const int P = cam.width * cam.height;
  buf.mesh = {};
  if (req.mesh_layer) {
    buf.mesh = *req.mesh_layer;
  } else if (req.texture) {
    if (req.texture->channels != 3) fail("render_avatar", "the texture must have 3 channels");
    render_mesh(cam, mesh_input(req), buf.mesh_render);
    buf.mesh.depth = buf.mesh_render.raster.depth.data();
    buf.mesh.color = buf.mesh_render.color.data();
    buf.mesh.mask = buf.mesh_render.raster.mask.data();
  }
  if (buf.mesh.depth && req.depth_margin != 0.0f) {
    buf.depth_tmp.resize(size_t(P));
    for (int p = 0; p < P; ++p) buf.depth_tmp[size_t(p)] = buf.mesh.depth[p] + req.depth_margin;
  }
  if (req.gaussians) {
    const GaussianSetView& g = *req.gaussians;
    buf.means.resize(3 * size_t(g.count));
    buf.quats.resize(4 * size_t(g.count));
    buf.scales.resize(3 * size_t(g.count));
    if (g.count > 0)
      pose_gaussians(req.verts, req.body->faces.data(), req.body->num_faces, req.face_scale_divisor, local_view(g),
                     buf.means.data(), buf.quats.data(), buf.scales.data());
    buf.color_front.resize(3 * size_t(P));
    buf.alpha.resize(size_t(P));
    GaussianRasterOutputs<float> out;
    out.color = buf.color_front.data();
    out.alpha = buf.alpha.data();
    rasterize_gaussians(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, out);
  } else {
    buf.color_front.assign(3 * size_t(P), 0.0f);
    buf.alpha.assign(size_t(P), 0.0f);
  }
  buf.image.resize(3 * size_t(P));
  merge(merge_inputs(req, buf), buf.image.data());
}

void render_avatar_backward(const AvatarRenderRequest& req, AvatarRenderBuffers& buf, const float* d_image,
                            const float* d_alpha_extra, const float* d_means_extra,
                            const AvatarRenderGrads& grads) {
  check_request(req, "render_avatar_backward");
  const Camera& cam = *req.camera;
  const int P = cam.width * cam.height;
  if (buf.width != cam.width || buf.height != cam.height) fail("render_avatar_backward", "no matching forward");
  const bool mesh_grad = req.texture && !req.mesh_layer && (grads.texture || grads.verts);
  MergeGrads mg;
  if (req.gaussians) {
    buf.d_color_front.resize(3 * size_t(P));
    buf.d_alpha.resize(size_t(P));
    mg.color_front = buf.d_color_front.data();
    mg.alpha = buf.d_alpha.data();
  }
  if (mesh_grad) {
    buf.d_mesh_color.resize(3 * size_t(P));
    mg.mesh_color = buf.d_mesh_color.data();
  }
  merge_backward(merge_inputs(req, buf), d_image, mg);

  if (req.gaussians && req.gaussians->count > 0) {
    const GaussianSetView& g = *req.gaussians;
    const size_t n = size_t(g.count);
    if (d_alpha_extra)
      for (int p = 0; p < P; ++p) buf.d_alpha[size_t(p)] += d_alpha_extra[p];
    buf.d_means.resize(3 * n);
    buf.d_quats.resize(4 * n);
    buf.d_scales.resize(3 * n);
    buf.d_opacity.resize(n);
    buf.d_color.resize(3 * n);
    GaussianRasterOutputGrads<float> dout;
    dout.color = buf.d_color_front.data();
    dout.alpha = buf.d_alpha.data();
    GaussianGrads<float> gg;
    gg.means = buf.d_means.data();
    gg.quats = buf.d_quats.data();
    gg.scales = buf.d_scales.data();
    gg.opacities = buf.d_opacity.data();
    gg.colors = buf.d_color.data();
    gg.means2d_norm_accum = grads.means2d_norm_accum;
    rasterize_gaussians_backward(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, dout, gg);
    if (d_means_extra)
      for (size_t i = 0; i < 3 * n; ++i) buf.d_means[i] += d_means_extra[i];
    if (grads.opacity)
      for (size_t i = 0; i < n; ++i) grads.opacity[i] += buf.d_opacity[i];
    if (grads.color)
      for (size_t i = 0; i < 3 * n; ++i) grads.color[i] += buf.d_color[i];
    if (grads.verts || grads.offset || grads.rotation || grads.scale) {
      // pose_gaussians_backward needs a d_verts buffer; route it to a scratch when unwanted.
      float* dv = grads.verts;
      std::vector<float> dv_scratch;
      if (!dv) {
        dv_scratch.assign(3 * size_t(req.body->num_verts), 0.0f);
        dv = dv_scratch.data();
      }
      pose_gaussians_backward(req.verts, req.body->faces.data(), req.body->num_faces, req.face_scale_divisor,
                              local_view(g), buf.d_means.data(), buf.d_quats.data(), buf.d_scales.data(), dv,
                              grads.offset, grads.rotation, grads.scale);
    }
  }
  if (mesh_grad)
    render_mesh_backward(cam, mesh_input(req), buf.mesh_render, buf.d_mesh_color.data(), nullptr, grads.texture,
                         grads.verts);
}

}  // namespace haha
