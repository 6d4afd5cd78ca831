// Per-pixel image operations on the GPU: the HAHA merge (render/merge.h) and the training
// image losses L2, SSIM and the edge ("Sobel") loss (train/losses.h), with the kernels of
// render/merge.h and train/loss_kernels.h. Buffer contracts are the CPU functions' (images
// (H, W, 3), optional weights (H, W), gradients ADDED as grad_scale * dL/dx), with device
// pointers. Loss values are summed in double on the device (atomics: the order differs
// from the CPU's fixed one) and read back, so each loss call synchronises once (twice with
// weights: the weight sum is read first, to form the same constants as the CPU).
#pragma once

#include "render/merge.h"
#include "cuda/runtime.h"

namespace haha::cuda {

// As merge / merge_backward; background_color (3, device) is ACCUMULATED.
void merge_cuda(const MergeInputs& in, float* out);
void merge_backward_cuda(const MergeInputs& in, const float* grad_out, const MergeGrads& grads);

// Elementwise helpers of the launch chains: y[i] += x[i]; y[i] = x[i] + s (i < n).
void add_cuda(int64_t n, const float* x, float* y);
void add_scalar_cuda(int64_t n, const float* x, float s, float* y);

// Scratch reused between loss calls.
struct LossCudaScratch {
  DeviceBuffer<float> maps;   // up to 10 H W values
  DeviceBuffer<double> sums;  // value accumulators
};

float l2_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& scratch,
                   const float* weights = nullptr, float* grad = nullptr, float grad_scale = 1.0f);
float ssim_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& scratch,
                     const float* weights = nullptr, float* grad = nullptr, float grad_scale = 1.0f);
float edge_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& scratch,
                     const float* weights = nullptr, float* grad = nullptr, float grad_scale = 1.0f);

}  // namespace haha::cuda
