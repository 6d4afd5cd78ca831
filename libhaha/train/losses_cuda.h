// The training image losses L2, SSIM and the edge ("Sobel") loss (train/losses.h) on the
// GPU, with the kernels of train/loss_kernels.h. Buffer contracts are the CPU functions'
// (images (H, W, 3), optional weights (H, W), gradients ADDED as grad_scale * dL/dx), with
// device pointers. Loss values are summed in double on the device (atomics: the order
// differs from the CPU's fixed one) and read back, so each loss call synchronises once
// (twice with weights: the weight sum is read first, to form the same constants as the CPU).
#pragma once

#include "cuda/runtime.h"

namespace haha::cuda {

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
