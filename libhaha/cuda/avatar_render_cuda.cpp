// Host-side chaining of the CUDA launchers (mirrors train/avatar_render.cpp step by step).
#include "cuda/avatar_render_cuda.h"

#include <string>

#include "cuda/image_cuda.h"
#include "render/merge.h"

namespace haha::cuda {

namespace {

void check_request(const AvatarRenderCudaRequest& req, const char* fn) {
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

MeshRenderInput mesh_input(const AvatarRenderCudaRequest& req) {
  const AvatarBodyCuda& b = *req.body;
  MeshRenderInput in;
  in.verts = req.verts;
  in.num_verts = b.num_verts;
  in.faces = b.faces.data();
  in.num_faces = b.num_faces;
  in.uv = b.uv.data();
  in.num_uv = b.num_uv;
  in.uv_faces = b.uv_faces.data();
  in.texture = *req.texture;
  return in;
}

GaussianLocalView<float> local_view(const GaussianSetView& g) {
  return {g.count, g.face, g.offset, g.rotation, g.scale};
}

GaussianInputs<float> raster_inputs(const AvatarRenderCudaBuffers& buf, const GaussianSetView& g) {
  GaussianInputs<float> in;
  in.count = g.count;
  in.means = buf.means.data();
  in.quats = buf.quats.data();
  in.scales = buf.scales.data();
  in.opacities = g.opacity;
  in.colors = g.color;
  return in;
}

GaussianRasterSettings<float> raster_settings(const AvatarRenderCudaRequest& req, const AvatarRenderCudaBuffers& buf) {
  GaussianRasterSettings<float> s;
  // No background inside the rasterizer: the merge adds what lies behind exactly once.
  s.background_color = Vec3f(0, 0, 0);
  if (req.mesh_layer || req.texture) s.depth_map = req.depth_margin != 0.0f ? buf.depth_tmp.data() : buf.mesh.depth;
  return s;
}

MergeInputs merge_inputs(const AvatarRenderCudaRequest& req, const AvatarRenderCudaBuffers& buf) {
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

AvatarBodyCuda::AvatarBodyCuda(const BodyModel& body)
    : num_verts(body.num_verts), num_faces(body.num_faces), num_uv(body.num_uv()) {
  const std::string where = body.source.empty() ? std::string("body model") : body.source;
  if (body.faces.size() != size_t(num_faces) * 3) fail(where, "faces: size does not match num_faces");
  for (size_t i = 0; i < body.faces.size(); ++i)
    if (body.faces[i] < 0 || body.faces[i] >= num_verts)
      fail(where, "faces: face " + std::to_string(i / 3) + " has vertex index " + std::to_string(body.faces[i]) +
                      " outside [0, " + std::to_string(num_verts) + ")");
  if (!body.ft.empty()) {
    if (body.ft.size() != body.faces.size()) fail(where, "ft: size does not match the faces");
    for (size_t i = 0; i < body.ft.size(); ++i)
      if (body.ft[i] < 0 || body.ft[i] >= num_uv)
        fail(where, "ft: face " + std::to_string(i / 3) + " has UV index " + std::to_string(body.ft[i]) +
                        " outside [0, " + std::to_string(num_uv) + ")");
  }
  faces.upload(body.faces);
  uv_faces.upload(body.ft);
  uv.upload(body.vt);
}

void render_avatar_cuda(const AvatarRenderCudaRequest& req, AvatarRenderCudaBuffers& buf) {
  check_request(req, "render_avatar_cuda");
  const Camera& cam = *req.camera;
  buf.width = cam.width;
  buf.height = cam.height;
  const int P = cam.width * cam.height;
  buf.mesh = {};
  if (req.mesh_layer) {
    buf.mesh = *req.mesh_layer;
  } else if (req.texture) {
    if (req.texture->channels != 3) fail("render_avatar_cuda", "the texture must have 3 channels");
    if (req.body->uv_faces.size() != size_t(req.body->num_faces) * 3) fail("render_avatar_cuda", "the body has no UVs");
    render_mesh_cuda(cam, mesh_input(req), buf.mesh_render);
    buf.mesh.depth = buf.mesh_render.raster.depth.data();
    buf.mesh.color = buf.mesh_render.color.data();
    buf.mesh.mask = buf.mesh_render.raster.mask.data();
  }
  if (buf.mesh.depth && req.depth_margin != 0.0f) {
    buf.depth_tmp.resize(size_t(P));
    add_scalar_cuda(P, buf.mesh.depth, req.depth_margin, buf.depth_tmp.data());
  }
  if (req.gaussians) {
    const GaussianSetView& g = *req.gaussians;
    buf.means.resize(3 * size_t(g.count));
    buf.quats.resize(4 * size_t(g.count));
    buf.scales.resize(3 * size_t(g.count));
    if (g.count > 0)
      pose_gaussians_cuda(req.verts, req.body->faces.data(), req.body->num_faces, req.face_scale_divisor, local_view(g),
                          buf.means.data(), buf.quats.data(), buf.scales.data(), buf.pose);
    buf.color_front.resize(3 * size_t(P));
    buf.alpha.resize(size_t(P));
    GaussianRasterOutputs<float> out;
    out.color = buf.color_front.data();
    out.alpha = buf.alpha.data();
    rasterize_gaussians_cuda(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, out);
  } else {
    buf.color_front.assign_zero(3 * size_t(P));
    buf.alpha.assign_zero(size_t(P));
  }
  buf.image.resize(3 * size_t(P));
  merge_cuda(merge_inputs(req, buf), buf.image.data());
}

void render_avatar_backward_cuda(const AvatarRenderCudaRequest& req, AvatarRenderCudaBuffers& buf,
                                 const float* d_image, const float* d_alpha_extra, const float* d_means_extra,
                                 const AvatarRenderGrads& grads) {
  check_request(req, "render_avatar_backward_cuda");
  const Camera& cam = *req.camera;
  const int P = cam.width * cam.height;
  if (buf.width != cam.width || buf.height != cam.height) fail("render_avatar_backward_cuda", "no matching forward");
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
  merge_backward_cuda(merge_inputs(req, buf), d_image, mg);

  if (req.gaussians && req.gaussians->count > 0) {
    const GaussianSetView& g = *req.gaussians;
    const size_t n = size_t(g.count);
    if (d_alpha_extra) add_cuda(P, d_alpha_extra, buf.d_alpha.data());
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
    rasterize_gaussians_backward_cuda(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, dout, gg);
    if (d_means_extra) add_cuda(int64_t(3 * n), d_means_extra, buf.d_means.data());
    if (grads.opacity) add_cuda(int64_t(n), buf.d_opacity.data(), grads.opacity);
    if (grads.color) add_cuda(int64_t(3 * n), buf.d_color.data(), grads.color);
    if (grads.verts || grads.offset || grads.rotation || grads.scale) {
      // pose_gaussians_backward needs a d_verts buffer; route it to a scratch when unwanted.
      float* dv = grads.verts;
      if (!dv) {
        buf.d_verts_scratch.assign_zero(3 * size_t(req.body->num_verts));
        dv = buf.d_verts_scratch.data();
      }
      pose_gaussians_backward_cuda(req.verts, req.body->faces.data(), req.body->num_faces, req.face_scale_divisor,
                                   local_view(g), buf.d_means.data(), buf.d_quats.data(), buf.d_scales.data(), dv,
                                   grads.offset, grads.rotation, grads.scale, buf.pose);
    }
  }
  if (mesh_grad)
    render_mesh_backward_cuda(cam, mesh_input(req), buf.mesh_render, buf.d_mesh_color.data(), nullptr, grads.texture,
                              grads.verts);
}

}  // namespace haha::cuda
