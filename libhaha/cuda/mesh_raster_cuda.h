// Mesh rasterization, interpolation and texture sampling on the GPU with the kernels of
// render/mesh_raster.h and render/texture.h:
//   - rasterize: one thread per vertex (camera space), one per face (setup_triangle), one
//     warp per face over its pixel box (tri_covers, then atomicMin on the packed key
//     depth bits << 32 | face: the nearest face wins, ties to the lower index as on the
//     CPU), one thread per pixel to resolve (barycentrics with the set-up normals);
//   - backward kernels scatter into vertex / attribute / texel gradients with atomicAdd.
// Pointers are device memory; face / UV indices must be valid (validate once after an
// upload with check_indices_cuda, cuda/face_frames_cuda.h). Results match the CPU path up
// to floating-point contraction (nvcc fuses multiply-adds): coverage can differ at pixel
// centres within rounding of an edge, and sums made with atomics are order-dependent.
#pragma once

#include <cstdint>

#include "core/camera.h"
#include "render/mesh_raster.h"
#include "render/render_mesh.h"
#include "render/texture.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

struct MeshRasterCuda {
  int width = 0, height = 0;
  DeviceBuffer<int32_t> tri;   // (H*W) visible face, -1 = none
  DeviceBuffer<float> bary;    // (H*W, 3)
  DeviceBuffer<float> depth;   // (H*W) camera z, +inf outside
  DeviceBuffer<float> mask;    // (H*W) 1 inside, 0 outside
  // scratch
  DeviceBuffer<float> cam_verts;
  DeviceBuffer<TriSetup> setup;
  DeviceBuffer<unsigned long long> zbuf;
  int num_pixels() const { return width * height; }
};

// Throws haha::Error ("rasterize_mesh_cuda: ...") for a bad camera, as the CPU path.
void rasterize_mesh_cuda(const Camera& cam, const MeshView& mesh, MeshRasterCuda& out);

// ADDS dL/dverts (V, 3) for dL/dbary (P, 3) and dL/ddepth (P, may be null).
void mesh_barycentrics_backward_cuda(const Camera& cam, const MeshView& mesh, const int32_t* tri,
                                     const float* grad_bary, const float* grad_depth, float* grad_verts);

// As interpolate / interpolate_backward (render/mesh_raster.h).
void interpolate_cuda(int num_pixels, const int32_t* tri, const float* bary, const int32_t* attr_index,
                      const float* attr, int channels, float* out);
void interpolate_backward_cuda(int num_pixels, const int32_t* tri, const float* bary, const int32_t* attr_index,
                               const float* attr, int channels, const float* grad_out, float* grad_attr,
                               float* grad_bary);

// As sample_texture / sample_texture_backward (render/texture.h); tex.data is device memory.
void sample_texture_cuda(const TextureView& tex, int num_pixels, const int32_t* tri, const float* uv, float* out);
void sample_texture_backward_cuda(const TextureView& tex, int num_pixels, const int32_t* tri, const float* uv,
                                  const float* grad_out, float* grad_texture, float* grad_uv);

// render_mesh on the GPU (render/render_mesh.h); MeshRenderInput with device pointers.
struct MeshRenderCuda {
  MeshRasterCuda raster;
  DeviceBuffer<float> uv, color;          // (P, 2), (P, C)
  DeviceBuffer<float> grad_uv, grad_bary;  // backward scratch
};
void render_mesh_cuda(const Camera& cam, const MeshRenderInput& in, MeshRenderCuda& out);
void render_mesh_backward_cuda(const Camera& cam, const MeshRenderInput& in, MeshRenderCuda& fwd,
                               const float* grad_color, const float* grad_depth, float* grad_texture,
                               float* grad_verts);

}  // namespace haha::cuda
