// The training losses L2, SSIM, the edge ("Sobel") loss, Dice, texture TV and the opacity
// regulariser (train/losses.h) on the
// GPU, with the kernels of train/loss_kernels.h. Buffer contracts are the CPU functions'
// (images (H, W, 3), optional weights (H, W), gradients ADDED as grad_scale * dL/dx), with
// device pointers. Loss values are summed in double on the device (atomics: the order
// differs from the CPU's fixed one) and read back, so each loss call synchronises once
// (twice with weights: the weight sum is read first, to form the same constants as the CPU).
#pragma once

#include <cstdint>

#include "cuda/cuda_base.h"
#include "train/losses.h"

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

// Dice, texture TV, the opacity and stretch regularisers (train/losses.h) with the per-element
// kernels of train/loss_kernels.h; device pointers, gradients ADDED; each reads its sums
// back once (synchronises).
float dice_loss_cuda(const float* p, const float* t, int64_t n, LossCudaScratch& scratch, float* grad = nullptr,
                     float grad_scale = 1.0f);
float texture_tv_loss_cuda(const float* tex, int H, int W, int C, LossCudaScratch& scratch, float* grad = nullptr,
                           float grad_scale = 1.0f);
float opacity_reg_cuda(const float* opacity, int64_t n, OpacityRegMode mode, LossCudaScratch& scratch,
                       float* grad = nullptr, float grad_scale = 1.0f);
// face, stretch (per face), offset, scale: device arrays as in stretch_reg.
float stretch_reg_cuda(const int32_t* face, const float* stretch, const float* offset, const float* scale, int64_t n,
                       LossCudaScratch& scratch, float* grad_offset = nullptr, float* grad_scale = nullptr,
                       float grad_k = 1.0f);

}  // namespace haha::cuda
