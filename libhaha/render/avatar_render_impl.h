// The merged avatar render and its backward, written once over a backend (the Open3D
// pattern: one implementation, thin launchers). Included by render/avatar_render.cpp
// (CpuRenderBackend) and cuda/avatar_render_cuda.cpp (the CUDA backend); nothing else
// includes it.
//
// A backend B provides, besides the types of AvatarRenderBuffersT:
//   assign_zero(Buffer<float>&, n)                      resize to n and set to 0
//   add(n, x, y) / add_scalar(n, x, s, y)               y += x / y = x + s
//   render_mesh(cam, MeshRenderInput, MeshRender&)      and render_mesh_backward
//   pose_gaussians(verts, faces, F, divisor, local, means, quats, scales, PoseScratch&)
//                                                       and pose_gaussians_backward
//   rasterize(in, cam, settings, RasterState&, out)     and rasterize_backward
//   antialias(AntialiasInputsT<float>, color, mask)      and antialias_backward
//   merge(MergeInputs, out)                             and merge_backward
// with the semantics of the CPU functions of the same names (render/, body/).
#pragma once

#include "core/error.h"
#include "render/avatar_render.h"
#include "render/merge.h"
#include "render/mesh_antialias.h"

namespace haha::avatar_render_detail {

inline void check_request(const AvatarRenderRequest& req, const char* fn) {
  if (!req.camera || req.camera->width <= 0 || req.camera->height <= 0) fail(fn, "no camera");
  if ((req.gaussians || req.texture) && (!req.body || !req.verts)) fail(fn, "no posed body");
  if (req.gaussians) {
    const GaussianSetView& g = *req.gaussians;
    if (g.count < 0 || (g.count > 0 && (!g.face || !g.offset || !g.rotation || !g.scale || !g.color || !g.opacity)))
      fail(fn, "incomplete Gaussian buffers");
  }
  if (req.mesh_layer && (!req.mesh_layer->depth || !req.mesh_layer->color || !req.mesh_layer->mask))
    fail(fn, "incomplete mesh layer");
  if (req.texture && !req.mesh_layer) {
    if (req.texture->channels != 3) fail(fn, "the texture must have 3 channels");
    if (!req.body->uv_faces || !req.body->uv) fail(fn, "the body has no UV map");
    if (req.antialias && !req.body->face_neighbors) fail(fn, "antialias needs the body's face neighbours");
  }
}

// Whether the mesh is rendered here and antialiased.
inline bool antialiased(const AvatarRenderRequest& req) { return req.antialias && req.texture && !req.mesh_layer; }

// The antialiasing pass over the mesh layer just rendered (colour and coverage before it).
template <class Buf>
AntialiasInputsT<float> aa_inputs(const AvatarRenderRequest& req, const Buf& buf) {
  AntialiasInputsT<float> in;
  in.camera = *req.camera;
  in.mesh = {req.verts, req.body->num_verts, req.body->faces, req.body->num_faces};
  in.neighbors = req.body->face_neighbors;
  in.tri = buf.mesh_render.raster.tri.data();
  in.depth = buf.mesh_render.raster.depth.data();
  in.color = buf.mesh_render.color.data();
  in.mask = buf.mesh_render.raster.mask.data();
  in.channels = 3;
  return in;
}

inline MeshRenderInput mesh_input(const AvatarRenderRequest& req) {
  const BodyTopology& b = *req.body;
  MeshRenderInput in;
  in.verts = req.verts;
  in.num_verts = b.num_verts;
  in.faces = b.faces;
  in.num_faces = b.num_faces;
  in.uv = b.uv;
  in.num_uv = b.num_uv;
  in.uv_faces = b.uv_faces;
  in.texture = *req.texture;
  in.coverage = req.mesh_coverage;
  return in;
}

inline GaussianLocalView<float> local_view(const GaussianSetView& g) {
  return {g.count, g.face, g.offset, g.rotation, g.scale};
}

template <class Buf>
GaussianInputs<float> raster_inputs(const Buf& buf, const GaussianSetView& g) {
  GaussianInputs<float> in;
  in.count = g.count;
  in.means = buf.means.data();
  in.quats = buf.quats.data();
  in.scales = buf.scales.data();
  in.opacities = g.opacity;
  in.colors = g.color;
  return in;
}

template <class Buf>
GaussianRasterSettings<float> raster_settings(const AvatarRenderRequest& req, const Buf& buf) {
  GaussianRasterSettings<float> s;
  // No background inside the rasterizer: the merge adds what lies behind exactly once.
  s.background_color = Vec3f(0, 0, 0);
  if (req.mesh_layer || req.texture) s.depth_map = req.depth_margin != 0.0f ? buf.depth_tmp.data() : buf.mesh.depth;
  return s;
}

template <class Buf>
MergeInputs merge_inputs(const AvatarRenderRequest& req, const Buf& buf) {
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

// B: the backend's operations; buf: an AvatarRenderBuffersT of that backend.
template <class B, class Buf>
void render(const AvatarRenderRequest& req, Buf& buf, const char* fn) {
  check_request(req, fn);
  const Camera& cam = *req.camera;
  buf.width = cam.width;
  buf.height = cam.height;
  const int P = cam.width * cam.height;
  buf.mesh = {};
  if (req.mesh_layer) {
    buf.mesh = *req.mesh_layer;
  } else if (req.texture) {
    B::render_mesh(cam, mesh_input(req), buf.mesh_render);
    buf.mesh.depth = buf.mesh_render.raster.depth.data();
    buf.mesh.color = buf.mesh_render.color.data();
    buf.mesh.mask = buf.mesh_render.raster.mask.data();
    if (antialiased(req)) {
      buf.aa_color.resize(3 * size_t(P));
      buf.aa_mask.resize(size_t(P));
      B::antialias(aa_inputs(req, buf), buf.aa_color.data(), buf.aa_mask.data());
      buf.mesh.color = buf.aa_color.data();
      buf.mesh.mask = buf.aa_mask.data();
    }
  }
  if (buf.mesh.depth && req.depth_margin != 0.0f) {
    buf.depth_tmp.resize(size_t(P));
    B::add_scalar(P, buf.mesh.depth, req.depth_margin, buf.depth_tmp.data());
  }
  if (req.gaussians) {
    const GaussianSetView& g = *req.gaussians;
    buf.means.resize(3 * size_t(g.count));
    buf.quats.resize(4 * size_t(g.count));
    buf.scales.resize(3 * size_t(g.count));
    if (g.count > 0)
      B::pose_gaussians(req.verts, req.body->faces, req.body->num_faces, req.face_scale_divisor, local_view(g),
                        buf.means.data(), buf.quats.data(), buf.scales.data(), buf.pose);
    buf.color_front.resize(3 * size_t(P));
    buf.alpha.resize(size_t(P));
    GaussianRasterOutputs<float> out;
    out.color = buf.color_front.data();
    out.alpha = buf.alpha.data();
    B::rasterize(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, out);
  } else {
    B::assign_zero(buf.color_front, 3 * size_t(P));
    B::assign_zero(buf.alpha, size_t(P));
  }
  buf.image.resize(3 * size_t(P));
  B::merge(merge_inputs(req, buf), buf.image.data());
}

template <class B, class Buf>
void render_backward(const AvatarRenderRequest& req, Buf& buf, const float* d_image,
                     const float* d_alpha_extra, const float* d_means_extra, const AvatarRenderGrads& grads,
                     const char* fn) {
  check_request(req, fn);
  const Camera& cam = *req.camera;
  const int P = cam.width * cam.height;
  if (buf.width != cam.width || buf.height != cam.height) fail(fn, "no matching forward");
  const bool mesh_grad = req.texture && !req.mesh_layer && (grads.texture || grads.verts);
  MergeGrads mg;
  if (req.gaussians) {
    buf.d_color_front.resize(3 * size_t(P));
    buf.d_alpha.resize(size_t(P));
    mg.color_front = buf.d_color_front.data();
    mg.alpha = buf.d_alpha.data();
    if (grads.removal_cost) {  // the removal cost needs what shows behind the Gaussians
      buf.under.resize(3 * size_t(P));
      mg.under = buf.under.data();
    }
  }
  if (mesh_grad) {
    buf.d_mesh_color.resize(3 * size_t(P));
    mg.mesh_color = buf.d_mesh_color.data();
    if (antialiased(req) && grads.verts) {  // the coverage moves with the silhouette
      buf.d_mesh_mask.resize(size_t(P));
      mg.mesh_mask = buf.d_mesh_mask.data();
    }
  }
  B::merge_backward(merge_inputs(req, buf), d_image, mg);

  if (req.gaussians && req.gaussians->count > 0) {
    const GaussianSetView& g = *req.gaussians;
    const size_t n = size_t(g.count);
    if (d_alpha_extra) B::add(P, d_alpha_extra, buf.d_alpha.data());
    buf.d_means.resize(3 * n);
    buf.d_quats.resize(4 * n);
    buf.d_scales.resize(3 * n);
    buf.d_opacity.resize(n);
    buf.d_color.resize(3 * n);
    GaussianRasterOutputGrads<float> dout;
    dout.color = buf.d_color_front.data();
    dout.alpha = buf.d_alpha.data();
    if (grads.removal_cost) dout.backdrop = buf.under.data();
    GaussianGrads<float> gg;
    gg.means = buf.d_means.data();
    gg.quats = buf.d_quats.data();
    gg.scales = buf.d_scales.data();
    gg.opacities = buf.d_opacity.data();
    gg.colors = buf.d_color.data();
    gg.means2d_norm_accum = grads.means2d_norm_accum;
    gg.means2d_norm_scale_x = grads.means2d_norm_scale[0];
    gg.means2d_norm_scale_y = grads.means2d_norm_scale[1];
    gg.removal_cost = grads.removal_cost;
    B::rasterize_backward(raster_inputs(buf, g), cam, raster_settings(req, buf), buf.raster, dout, gg);
    if (d_means_extra) B::add(int64_t(3 * n), d_means_extra, buf.d_means.data());
    if (grads.opacity) B::add(int64_t(n), buf.d_opacity.data(), grads.opacity);
    if (grads.color) B::add(int64_t(3 * n), buf.d_color.data(), grads.color);
    if (grads.verts || grads.offset || grads.rotation || grads.scale) {
      // pose_gaussians_backward needs a d_verts buffer; route it to a scratch when unwanted.
      float* dv = grads.verts;
      if (!dv) {
        B::assign_zero(buf.d_verts_scratch, 3 * size_t(req.body->num_verts));
        dv = buf.d_verts_scratch.data();
      }
      B::pose_gaussians_backward(req.verts, req.body->faces, req.body->num_faces, req.face_scale_divisor, local_view(g),
                                 buf.d_means.data(), buf.d_quats.data(), buf.d_scales.data(), dv, grads.offset,
                                 grads.rotation, grads.scale, buf.pose);
    }
  }
  if (mesh_grad) {
    const float* d_color = buf.d_mesh_color.data();
    if (antialiased(req)) {
      B::assign_zero(buf.d_mesh_color_raw, 3 * size_t(P));
      B::antialias_backward(aa_inputs(req, buf), buf.d_mesh_color.data(), mg.mesh_mask, buf.d_mesh_color_raw.data(),
                            grads.verts);
      d_color = buf.d_mesh_color_raw.data();
    }
    B::render_mesh_backward(cam, mesh_input(req), buf.mesh_render, d_color, grads.texture, grads.verts);
  }
}

}  // namespace haha::avatar_render_detail
