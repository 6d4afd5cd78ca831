// The HAHA merge (render/merge.h) on the GPU, with its kernels, and the elementwise helpers
// of the launch chains. Buffer contracts are the CPU functions', with device pointers.
#pragma once

#include "render/merge.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// As merge / merge_backward; background_color (3, device) is ACCUMULATED.
void merge_cuda(const MergeInputs& in, float* out);
void merge_backward_cuda(const MergeInputs& in, const float* grad_out, const MergeGrads& grads);

// y[i] += x[i]; y[i] = x[i] + s (i < n).
void add_cuda(int64_t n, const float* x, float* y);
void add_scalar_cuda(int64_t n, const float* x, float s, float* y);

}  // namespace haha::cuda
