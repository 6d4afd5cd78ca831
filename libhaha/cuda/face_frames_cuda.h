// Face frames and face-bound Gaussians on the GPU (body/face_frames.h kernels): one thread
// per face for the frames, one per Gaussian for the transform. The backward adds each
// Gaussian's frame gradient into its face atomically (the CPU groups by face instead),
// then each face scatters its corner gradients into the vertices atomically.
// All pointers are device memory; face indices must be valid (check_face_indices_cuda
// once after an upload: the launchers do not re-check them every call).
#pragma once

#include <cstdint>
#include <type_traits>

#include "body/face_frames.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// frames (F) from verts (V, 3), faces (F, 3).
void face_frames_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                      FaceFrame<float>* frames);

// ADDS dL/dverts (V, 3) for dL/dframes (F).
void face_frames_backward_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                               const FaceFrameGrad<float>* d_frames, float* d_verts);

// Scratch of pose_gaussians(_backward)_cuda, reused between calls.
struct PoseGaussiansScratch {
  DeviceBuffer<FaceFrame<float>> frames;       // (F)
  DeviceBuffer<FaceFrameGrad<float>> d_frames;  // (F)
};

// World-space Gaussians: means (N, 3), quats (N, 4), scales (N, 3), device outputs.
void pose_gaussians_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                         const GaussianLocalView<float>& g, float* means, float* quats, float* scales,
                         PoseGaussiansScratch& scratch);

// Backward (as pose_gaussians_backward): d_means / d_quats / d_scales may be null (zero);
// ADDS into d_verts, d_offset, d_rotation, d_scale where non-null.
void pose_gaussians_backward_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                                  const GaussianLocalView<float>& g, const float* d_means, const float* d_quats,
                                  const float* d_scales, float* d_verts, float* d_offset, float* d_rotation,
                                  float* d_scale, PoseGaussiansScratch& scratch);

// Throws haha::Error "<where>: index <i> is <v>, outside [0, limit)" when a value of idx
// (n, device) is out of range. Synchronises.
void check_indices_cuda(const int32_t* idx, int64_t n, int limit, const char* where);

}  // namespace haha::cuda
