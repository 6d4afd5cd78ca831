// The HAHA avatar render (train/avatar_render.h) on the GPU: the same chain and the same
// semantics, launcher for launcher,
//   posed vertices --face frames--> world Gaussians --raster (occluded by D)--> C_front, A
//   posed vertices --mesh raster + texture--> M, D, m
//   I = C_front + (1 - A) (m M + (1 - m) B)
// and its backward to the posed vertices, the local Gaussian parameters and the texture.
// Everything per frame stays on the device; the only read-back is the rasterizer's pair
// count. The structs of train/avatar_render.h (GaussianSetView, MeshLayerView,
// AvatarRenderGrads) are reused with DEVICE pointers.
#pragma once

#include <cstdint>

#include "body/body_model.h"
#include "render/camera.h"
#include "render/texture.h"
#include "train/avatar_render.h"
#include "cuda/face_frames_cuda.h"
#include "cuda/gaussian_raster_cuda.h"
#include "cuda/mesh_raster_cuda.h"
#include "cuda/runtime.h"

namespace haha::cuda {

// The body's fixed topology on the device: faces, UV faces (ft) and UVs (vt). The
// constructor checks the index ranges on the host (haha::Error naming body.source).
struct AvatarBodyCuda {
  int num_verts = 0, num_faces = 0, num_uv = 0;
  DeviceBuffer<int32_t> faces, uv_faces;
  DeviceBuffer<float> uv;
  explicit AvatarBodyCuda(const BodyModel& body);
};

struct AvatarRenderCudaRequest {
  const Camera* camera = nullptr;
  const AvatarBodyCuda* body = nullptr;
  const float* verts = nullptr;  // device (V, 3) posed body
  float face_scale_divisor = 1.0f;
  const GaussianSetView* gaussians = nullptr;  // device pointers; null: no Gaussian layer
  const MeshLayerView* mesh_layer = nullptr;   // device pointers; precomputed mesh layer
  const TextureView* texture = nullptr;        // device texel data; mesh rendered here
  float depth_margin = 0.0f;
  float background[3] = {0, 0, 0};
};

// Outputs and scratch, reused between calls (device).
struct AvatarRenderCudaBuffers {
  int width = 0, height = 0;
  DeviceBuffer<float> image, color_front, alpha;  // (P, 3), (P, 3), (P)
  MeshLayerView mesh;                             // the mesh layer used (device pointers)
  MeshRenderCuda mesh_render;
  DeviceBuffer<float> means, quats, scales;  // posed Gaussians
  GaussianRasterCudaState raster;
  PoseGaussiansScratch pose;
  DeviceBuffer<float> depth_tmp;
  DeviceBuffer<float> d_color_front, d_alpha, d_mesh_color, d_means, d_quats, d_scales, d_opacity, d_color,
      d_verts_scratch;
};

void render_avatar_cuda(const AvatarRenderCudaRequest& req, AvatarRenderCudaBuffers& buf);

// d_image (P, 3), d_alpha_extra (P, may be null), d_means_extra (N, 3, may be null): device.
// Gradients ACCUMULATED into `grads` (device pointers), as render_avatar_backward.
void render_avatar_backward_cuda(const AvatarRenderCudaRequest& req, AvatarRenderCudaBuffers& buf,
                                 const float* d_image, const float* d_alpha_extra, const float* d_means_extra,
                                 const AvatarRenderGrads& grads);

}  // namespace haha::cuda
