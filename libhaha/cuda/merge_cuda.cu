#include "cuda/merge_cuda.h"

#include "cuda/device_util.cuh"

namespace haha::cuda {

namespace {

using detail::block_sum_atomic;
using detail::global_index;

__global__ void merge_kernel(MergeInputs in, float* out) {
  const int64_t p = global_index();
  if (p >= in.num_pixels) return;
  merge_pixel(in, p, out);
}

__global__ void merge_backward_kernel(MergeInputs in, const float* grad_out, MergeGrads grads, bool bg_colour) {
  const int64_t p = global_index();
  float gbg[3] = {0.0f, 0.0f, 0.0f};
  if (p < in.num_pixels) merge_backward_pixel(in, p, grad_out, grads, bg_colour, gbg);
  if (bg_colour)
    for (int c = 0; c < 3; ++c) block_sum_atomic(gbg[c], grads.background_color + c);
}

void check_merge(const MergeInputs& in, const char* fn) {
  if (in.num_pixels < 0) fail(fn, "negative pixel count");
  if (in.mesh_mask && !in.mesh_color) fail(fn, "mesh mask given without mesh colour");
}

__global__ void add_kernel(int64_t n, const float* x, float* y) {
  const int64_t i = global_index();
  if (i < n) y[i] += x[i];
}

__global__ void add_scalar_kernel(int64_t n, const float* x, float s, float* y) {
  const int64_t i = global_index();
  if (i < n) y[i] = x[i] + s;
}

}  // namespace

void merge_cuda(const MergeInputs& in, float* out) {
  check_merge(in, "merge_cuda");
  HAHA_LAUNCH(merge_kernel, in.num_pixels, detail::kThreads, 0, in, out);
}

void merge_backward_cuda(const MergeInputs& in, const float* grad_out, const MergeGrads& grads) {
  check_merge(in, "merge_backward_cuda");
  const bool bg_colour = !in.background && grads.background_color;
  HAHA_LAUNCH(merge_backward_kernel, in.num_pixels, detail::kThreads, 0, in, grad_out, grads, bg_colour);
}

void add_cuda(int64_t n, const float* x, float* y) { HAHA_LAUNCH(add_kernel, n, detail::kThreads, 0, n, x, y); }

void add_scalar_cuda(int64_t n, const float* x, float s, float* y) {
  HAHA_LAUNCH(add_scalar_kernel, n, detail::kThreads, 0, n, x, s, y);
}

}  // namespace haha::cuda
