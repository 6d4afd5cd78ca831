// The CPU launcher of the merged avatar render (render/avatar_render_impl.h).
#include "render/avatar_render.h"

#include "body/face_frames.h"
#include "render/avatar_render_impl.h"

namespace haha {

namespace {

// CpuRenderBackend's operations (render/avatar_render_impl.h lists them).
struct Cpu : CpuRenderBackend {
  static void assign_zero(std::vector<float>& b, size_t n) { b.assign(n, 0.0f); }
  static void add(int64_t n, const float* x, float* y) {
    for (int64_t i = 0; i < n; ++i) y[i] += x[i];
  }
  static void add_scalar(int64_t n, const float* x, float s, float* y) {
    for (int64_t i = 0; i < n; ++i) y[i] = x[i] + s;
  }
  static void render_mesh(const Camera& cam, const MeshRenderInput& in, MeshRender& out) {
    haha::render_mesh(cam, in, out);
  }
  static void render_mesh_backward(const Camera& cam, const MeshRenderInput& in, MeshRender& fwd, const float* d_color,
                                   float* d_texture, float* d_verts) {
    haha::render_mesh_backward(cam, in, fwd, d_color, nullptr, d_texture, d_verts);
  }
  static void pose_gaussians(const float* verts, const int32_t* faces, int num_faces, float divisor,
                             const GaussianLocalView<float>& g, float* means, float* quats, float* scales, PoseScratch&) {
    haha::pose_gaussians(verts, faces, num_faces, divisor, g, means, quats, scales);
  }
  static void pose_gaussians_backward(const float* verts, const int32_t* faces, int num_faces, float divisor,
                                      const GaussianLocalView<float>& g, const float* d_means, const float* d_quats,
                                      const float* d_scales, float* d_verts, float* d_offset, float* d_rotation,
                                      float* d_scale, PoseScratch&) {
    haha::pose_gaussians_backward(verts, faces, num_faces, divisor, g, d_means, d_quats, d_scales, d_verts, d_offset,
                                  d_rotation, d_scale);
  }
  static void rasterize(const GaussianInputs<float>& in, const Camera& cam, const GaussianRasterSettings<float>& s,
                        RasterState& state, const GaussianRasterOutputs<float>& out) {
    rasterize_gaussians(in, cam, s, state, out);
  }
  static void rasterize_backward(const GaussianInputs<float>& in, const Camera& cam,
                                 const GaussianRasterSettings<float>& s, RasterState& state,
                                 const GaussianRasterOutputGrads<float>& dout, const GaussianGrads<float>& grads) {
    rasterize_gaussians_backward(in, cam, s, state, dout, grads);
  }
  static void antialias(const AntialiasInputsT<float>& in, float* color_out, float* mask_out) {
    haha::antialias(in, color_out, mask_out);
  }
  static void antialias_backward(const AntialiasInputsT<float>& in, const float* d_color_out, const float* d_mask_out,
                                 float* d_color, float* d_verts) {
    haha::antialias_backward(in, d_color_out, d_mask_out, d_color, nullptr, d_verts);
  }
  static void merge(const MergeInputs& in, float* out) { haha::merge(in, out); }
  static void merge_backward(const MergeInputs& in, const float* d_out, const MergeGrads& grads) {
    haha::merge_backward(in, d_out, grads);
  }
};

}  // namespace

BodyTopology topology_of(const BodyModel& body) {
  BodyTopology t;
  t.num_verts = body.num_verts;
  t.num_faces = body.num_faces;
  t.num_uv = body.num_uv();
  t.faces = body.faces.data();
  t.uv = body.vt.empty() ? nullptr : body.vt.data();
  t.uv_faces = body.ft.empty() ? nullptr : body.ft.data();
  return t;
}

AvatarViews::AvatarViews(const Avatar& a)
    : face_neighbors(mesh_face_neighbors(a.body.faces.data(), a.body.num_faces, a.body.num_verts)),
      body(topology_of(a.body)),
      gaussians{a.gaussians.size(),          a.gaussians.face.data(),  a.gaussians.offset.data(),
                a.gaussians.rotation.data(), a.gaussians.scale.data(), a.gaussians.color.data(),
                a.gaussians.opacity.data()},
      texture{a.texture.width, a.texture.height, 3, a.texture.rgb.data()} {
  body.face_neighbors = face_neighbors.data();
}

AvatarRenderRequest avatar_request(const Avatar& a, const AvatarViews& views, const Camera& cam, const float* verts,
                                   bool mesh, bool gaussians) {
  AvatarRenderRequest req;
  req.camera = &cam;
  req.body = &views.body;
  req.verts = verts;
  req.face_scale_divisor = a.face_scale_divisor;
  req.gaussians = gaussians ? &views.gaussians : nullptr;
  req.texture = mesh ? &views.texture : nullptr;
  req.mesh_coverage = a.mesh_coverage.empty() ? nullptr : a.mesh_coverage.data();
  req.depth_margin = a.depth_margin;
  return req;
}

void render_avatar(const AvatarRenderRequest& req, AvatarRenderBuffers& buf) {
  avatar_render_detail::render<Cpu>(req, buf, "render_avatar");
}

void render_avatar_backward(const AvatarRenderRequest& req, AvatarRenderBuffers& buf, const float* d_image,
                            const float* d_alpha_extra, const float* d_means_extra, const AvatarRenderGrads& grads) {
  avatar_render_detail::render_backward<Cpu>(req, buf, d_image,
                                             d_alpha_extra, d_means_extra, grads, "render_avatar_backward");
}

}  // namespace haha
