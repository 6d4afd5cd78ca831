// The CUDA launcher of the merged avatar render (render/avatar_render_impl.h).
#include "cuda/avatar_render_cuda.h"

#include <string>

#include "cuda/merge_cuda.h"
#include "cuda/mesh_antialias_cuda.h"
#include "render/avatar_render_impl.h"

namespace haha::cuda {

namespace {

// CudaRenderBackend's operations (render/avatar_render_impl.h lists them).
struct Cuda : CudaRenderBackend {
  static void assign_zero(DeviceBuffer<float>& b, size_t n) { b.assign_zero(n); }
  static void add(int64_t n, const float* x, float* y) { add_cuda(n, x, y); }
  static void add_scalar(int64_t n, const float* x, float s, float* y) { add_scalar_cuda(n, x, s, y); }
  static void render_mesh(const Camera& cam, const MeshRenderInput& in, MeshRender& out) {
    render_mesh_cuda(cam, in, out);
  }
  static void render_mesh_backward(const Camera& cam, const MeshRenderInput& in, MeshRender& fwd, const float* d_color,
                                   float* d_texture, float* d_verts) {
    render_mesh_backward_cuda(cam, in, fwd, d_color, nullptr, d_texture, d_verts);
  }
  static void pose_gaussians(const float* verts, const int32_t* faces, int num_faces, float divisor,
                             const GaussianLocalView<float>& g, float* means, float* quats, float* scales,
                             PoseScratch& scratch) {
    pose_gaussians_cuda(verts, faces, num_faces, divisor, g, means, quats, scales, scratch);
  }
  static void pose_gaussians_backward(const float* verts, const int32_t* faces, int num_faces, float divisor,
                                      const GaussianLocalView<float>& g, const float* d_means, const float* d_quats,
                                      const float* d_scales, float* d_verts, float* d_offset, float* d_rotation,
                                      float* d_scale, PoseScratch& scratch) {
    pose_gaussians_backward_cuda(verts, faces, num_faces, divisor, g, d_means, d_quats, d_scales, d_verts, d_offset,
                                 d_rotation, d_scale, scratch);
  }
  static void rasterize(const GaussianInputs<float>& in, const Camera& cam, const GaussianRasterSettings<float>& s,
                        RasterState& state, const GaussianRasterOutputs<float>& out) {
    rasterize_gaussians_cuda(in, cam, s, state, out);
  }
  static void rasterize_backward(const GaussianInputs<float>& in, const Camera& cam,
                                 const GaussianRasterSettings<float>& s, RasterState& state,
                                 const GaussianRasterOutputGrads<float>& dout, const GaussianGrads<float>& grads) {
    rasterize_gaussians_backward_cuda(in, cam, s, state, dout, grads);
  }
  static void antialias(const AntialiasInputsT<float>& in, float* color_out, float* mask_out) {
    antialias_cuda(in, color_out, mask_out);
  }
  static void antialias_backward(const AntialiasInputsT<float>& in, const float* d_color_out, const float* d_mask_out,
                                 float* d_color, float* d_verts) {
    antialias_backward_cuda(in, d_color_out, d_mask_out, d_color, d_verts);
  }
  static void merge(const MergeInputs& in, float* out) { merge_cuda(in, out); }
  static void merge_backward(const MergeInputs& in, const float* d_out, const MergeGrads& grads) {
    merge_backward_cuda(in, d_out, grads);
  }
};

}  // namespace

AvatarBodyCuda::AvatarBodyCuda(const BodyModel& body) {
  const int num_verts = body.num_verts, num_faces = body.num_faces, num_uv = body.num_uv();
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
  face_neighbors.upload(mesh_face_neighbors(body.faces.data(), num_faces, num_verts));
  uv_faces.upload(body.ft);
  uv.upload(body.vt);
  topology.num_verts = num_verts;
  topology.num_faces = num_faces;
  topology.num_uv = num_uv;
  topology.faces = faces.data();
  topology.face_neighbors = face_neighbors.data();
  topology.uv = uv.empty() ? nullptr : uv.data();
  topology.uv_faces = uv_faces.empty() ? nullptr : uv_faces.data();
}

void render_avatar_cuda(const AvatarRenderRequest& req, AvatarRenderCudaBuffers& buf) {
  avatar_render_detail::render<Cuda>(req, buf, "render_avatar_cuda");
}

void render_avatar_backward_cuda(const AvatarRenderRequest& req, AvatarRenderCudaBuffers& buf, const float* d_image,
                                 const float* d_alpha_extra, const float* d_means_extra,
                                 const AvatarRenderGrads& grads) {
  avatar_render_detail::render_backward<Cuda>(req, buf, d_image, d_alpha_extra, d_means_extra, grads,
                                              "render_avatar_backward_cuda");
}

}  // namespace haha::cuda
