// The merged avatar render (render/avatar_render.h) on the GPU: the same orchestration
// (render/avatar_render_impl.h) over the CUDA launchers, with the same request and
// gradient structs holding DEVICE pointers. Everything per frame stays on the device; the
// only read-back is the rasterizer's pair count.
#pragma once

#include <cstdint>

#include "body/body_model.h"
#include "render/avatar_render.h"
#include "cuda/face_frames_cuda.h"
#include "cuda/gaussian_raster_cuda.h"
#include "cuda/mesh_raster_cuda.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// The body's fixed topology on the device: faces, UV faces (ft), UVs (vt) and the faces'
// neighbours (for antialiasing). The
// constructor checks the index ranges on the host (haha::Error naming body.source).
// `topology` points into the device buffers: pass &body.topology as the request's body.
struct AvatarBodyCuda {
  DeviceBuffer<int32_t> faces, uv_faces, face_neighbors;
  DeviceBuffer<float> uv;
  BodyTopology topology;
  explicit AvatarBodyCuda(const BodyModel& body);
};

struct CudaRenderBackend {
  template <class T>
  using Buffer = DeviceBuffer<T>;
  using MeshRender = MeshRenderCuda;
  using RasterState = GaussianRasterCudaState;
  using PoseScratch = PoseGaussiansScratch;
};
using AvatarRenderCudaBuffers = AvatarRenderBuffersT<CudaRenderBackend>;

// As render_avatar / render_avatar_backward, with device pointers in the request, d_image
// (P, 3), d_alpha_extra (P), d_means_extra (N, 3) and `grads` (ACCUMULATED).
void render_avatar_cuda(const AvatarRenderRequest& req, AvatarRenderCudaBuffers& buf);
void render_avatar_backward_cuda(const AvatarRenderRequest& req, AvatarRenderCudaBuffers& buf, const float* d_image,
                                 const float* d_alpha_extra, const float* d_means_extra,
                                 const AvatarRenderGrads& grads);

}  // namespace haha::cuda
