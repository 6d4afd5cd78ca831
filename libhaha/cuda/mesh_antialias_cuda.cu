#include "cuda/mesh_antialias_cuda.h"

#include "core/error.h"
#include "cuda/device_util.cuh"

namespace haha::cuda {

namespace {

using detail::global_index;

__global__ void antialias_kernel(AntialiasInputsT<float> in, float* color_out, float* mask_out) {
  const int64_t p = global_index();
  const int W = in.camera.width;
  if (p >= int64_t(W) * in.camera.height) return;
  antialias_pixel(in, int(p % W), int(p / W), color_out + p * in.channels, mask_out + p);
}

__global__ void antialias_backward_kernel(AntialiasInputsT<float> in, const float* grad_color_out,
                                          const float* grad_mask_out, float* grad_color, float* grad_verts) {
  const int64_t p = global_index();
  const int W = in.camera.width;
  if (p >= int64_t(W) * in.camera.height) return;
  antialias_backward_pixel(in, int(p % W), int(p / W), grad_color_out + p * in.channels,
                           grad_mask_out ? grad_mask_out[p] : 0.0f, grad_color, static_cast<float*>(nullptr),
                           grad_verts, detail::AtomicAdd{});
}

void check(const AntialiasInputsT<float>& in, const char* fn) {
  if (in.camera.width <= 0 || in.camera.height <= 0) fail(fn, "no camera");
  if (!in.tri || !in.depth || !in.color || !in.mask || !in.neighbors) fail(fn, "missing input buffers");
  if (in.channels < 1 || in.channels > 8) fail(fn, "channels must be in [1, 8]");
}

}  // namespace

void antialias_cuda(const AntialiasInputsT<float>& in, float* color_out, float* mask_out) {
  check(in, "antialias_cuda");
  HAHA_LAUNCH(antialias_kernel, int64_t(in.camera.width) * in.camera.height, detail::kThreads, 0, in, color_out,
              mask_out);
}

void antialias_backward_cuda(const AntialiasInputsT<float>& in, const float* grad_color_out,
                             const float* grad_mask_out, float* grad_color, float* grad_verts) {
  check(in, "antialias_backward_cuda");
  if (!grad_verts && !grad_color) return;
  HAHA_LAUNCH(antialias_backward_kernel, int64_t(in.camera.width) * in.camera.height, detail::kThreads, 0, in,
              grad_color_out, grad_mask_out, grad_color, grad_verts);
}

}  // namespace haha::cuda
