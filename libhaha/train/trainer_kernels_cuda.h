// The CUDA trainer's small per-element kernels (train/trainer_cuda.cpp), each the device
// twin of a host loop of the CPU trainer and built on the same HAHA_HD function:
// activations (train/gaussian_params.h), the ground-truth composite and the silhouette
// union (train/image_loss.h), the unit rotation of the KNN term, the visibility count of
// the densification statistic, the texture clamp and a non-finite check. Pointers are
// device memory; nothing here synchronises except nonfinite_count().
#pragma once

#include <cstdint>

#include "cuda/cuda_base.h"

namespace haha::cuda {

// activate(): scale = scale_max sigmoid, colour / opacity = sigmoid (n Gaussians).
void activate_cuda(const float* scale_logit, const float* color_logit, const float* opacity_logit, int n,
                   float scale_max, float* scale, float* color, float* opacity);
// activation_backward(): logit gradients from activated ones (pointer pairs may be null);
// OVERWRITES the outputs.
void activation_backward_cuda(const float* scale, const float* color, const float* opacity, float scale_max, int n,
                              const float* d_scale, const float* d_color, const float* d_opacity,
                              float* d_scale_logit, float* d_color_logit, float* d_opacity_logit);

// composite_ground_truth(); bg: 3 host values.
void composite_ground_truth_cuda(const float* rgb, const float* mask, int num_pixels, bool premultiplied,
                                 const float bg[3], float* out);

// silhouette_union / silhouette_union_backward (d_alpha OVERWRITTEN).
void silhouette_union_cuda(const float* mesh_mask, const float* alpha, int num_pixels, float* out);
void silhouette_union_backward_cuda(const float* mesh_mask, const float* d_union, int num_pixels, float* d_alpha);

// out (n, 4) = normalize_quat(r); d_r (n, 4) += normalize_quat_backward(r, d_n).
void normalize_quats_cuda(const float* r, int n, float* out);
void normalize_quats_backward_add_cuda(const float* r, const float* d_n, int n, float* d_r);

// count[i] += 1 where radii[i] > 0 (the views that saw Gaussian i).
void count_visible_cuda(const int32_t* radii, int n, float* count);

// x = clamp(x, 0, 1).
void clamp01_cuda(float* x, int64_t n);

// Non-finite values of x (n) are counted into *counter (device int); read it back with
// nonfinite_count (synchronises).
void count_nonfinite_cuda(const float* x, int64_t n, int32_t* counter);
int32_t nonfinite_count(const DeviceBuffer<int32_t>& counter);

}  // namespace haha::cuda
