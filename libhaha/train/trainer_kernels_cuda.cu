#include "train/trainer_kernels_cuda.h"

#include <cmath>

#include "cuda/device_util.cuh"
#include "train/gaussian_params.h"
#include "train/image_loss.h"

namespace haha::cuda {

namespace {

using detail::global_index;

__global__ void activate_kernel(const float* sl, const float* cl, const float* ol, int n, float smax, float* s,
                                float* c, float* o) {
  const int64_t i = global_index();
  if (i >= n) return;
  for (int k = 0; k < 3; ++k) {
    s[3 * i + k] = scaled_sigmoid(sl[3 * i + k], smax);
    c[3 * i + k] = sigmoid(cl[3 * i + k]);
  }
  o[i] = sigmoid(ol[i]);
}

__global__ void activation_backward_kernel(const float* s, const float* c, const float* o, float smax, int n,
                                           const float* ds, const float* dc, const float* dop, float* dsl, float* dcl,
                                           float* dol) {
  const int64_t i = global_index();
  if (i >= n) return;
  for (int k = 0; k < 3; ++k) {
    if (ds && dsl) dsl[3 * i + k] = ds[3 * i + k] * scaled_sigmoid_grad_from_output(s[3 * i + k], smax);
    if (dc && dcl) dcl[3 * i + k] = dc[3 * i + k] * scaled_sigmoid_grad_from_output(c[3 * i + k], 1.0f);
  }
  if (dop && dol) dol[i] = dop[i] * scaled_sigmoid_grad_from_output(o[i], 1.0f);
}

struct Bg {
  float c[3];
};

__global__ void composite_kernel(const float* rgb, const float* mask, int P, bool premultiplied, Bg bg, float* out) {
  const int64_t p = global_index();
  if (p < P) composite_ground_truth_pixel(rgb, mask, p, premultiplied, bg.c, out);
}

__global__ void union_kernel(const float* m, const float* a, int P, float* out) {
  const int64_t p = global_index();
  if (p < P) out[p] = silhouette_union_value(m ? m[p] : 0.0f, a ? a[p] : 0.0f);
}

__global__ void union_backward_kernel(const float* m, const float* du, int P, float* da) {
  const int64_t p = global_index();
  if (p < P) da[p] = silhouette_union_grad(m ? m[p] : 0.0f, du[p]);
}

__global__ void normalize_kernel(const float* r, int n, float* out) {
  const int64_t i = global_index();
  if (i < n) normalize_quat(r + 4 * i, out + 4 * i);
}

__global__ void normalize_backward_kernel(const float* r, const float* dn, int n, float* dr) {
  const int64_t i = global_index();
  if (i >= n) return;
  float d[4];
  normalize_quat_backward(r + 4 * i, dn + 4 * i, d);
  for (int c = 0; c < 4; ++c) dr[4 * i + c] += d[c];
}

__global__ void count_visible_kernel(const int32_t* radii, int n, float* count) {
  const int64_t i = global_index();
  if (i < n && radii[i] > 0) count[i] += 1.0f;
}

__global__ void clamp01_kernel(float* x, int64_t n) {
  const int64_t i = global_index();
  if (i < n) x[i] = x[i] < 0.0f ? 0.0f : (1.0f < x[i] ? 1.0f : x[i]);  // std::clamp's order
}

__global__ void nonfinite_kernel(const float* x, int64_t n, int32_t* counter) {
  const int64_t i = global_index();
  if (i < n && !isfinite(x[i])) atomicAdd(counter, 1);
}

}  // namespace

void activate_cuda(const float* scale_logit, const float* color_logit, const float* opacity_logit, int n,
                   float scale_max, float* scale, float* color, float* opacity) {
  HAHA_LAUNCH(activate_kernel, n, detail::kThreads, 0, scale_logit, color_logit, opacity_logit, n, scale_max, scale,
              color, opacity);
}

void activation_backward_cuda(const float* scale, const float* color, const float* opacity, float scale_max, int n,
                              const float* d_scale, const float* d_color, const float* d_opacity,
                              float* d_scale_logit, float* d_color_logit, float* d_opacity_logit) {
  HAHA_LAUNCH(activation_backward_kernel, n, detail::kThreads, 0, scale, color, opacity, scale_max, n, d_scale,
              d_color, d_opacity, d_scale_logit, d_color_logit, d_opacity_logit);
}

void composite_ground_truth_cuda(const float* rgb, const float* mask, int num_pixels, bool premultiplied,
                                 const float bg[3], float* out) {
  const Bg b{{bg[0], bg[1], bg[2]}};
  HAHA_LAUNCH(composite_kernel, num_pixels, detail::kThreads, 0, rgb, mask, num_pixels, premultiplied, b, out);
}

void silhouette_union_cuda(const float* mesh_mask, const float* alpha, int num_pixels, float* out) {
  HAHA_LAUNCH(union_kernel, num_pixels, detail::kThreads, 0, mesh_mask, alpha, num_pixels, out);
}

void silhouette_union_backward_cuda(const float* mesh_mask, const float* d_union, int num_pixels, float* d_alpha) {
  HAHA_LAUNCH(union_backward_kernel, num_pixels, detail::kThreads, 0, mesh_mask, d_union, num_pixels, d_alpha);
}

void normalize_quats_cuda(const float* r, int n, float* out) {
  HAHA_LAUNCH(normalize_kernel, n, detail::kThreads, 0, r, n, out);
}

void normalize_quats_backward_add_cuda(const float* r, const float* d_n, int n, float* d_r) {
  HAHA_LAUNCH(normalize_backward_kernel, n, detail::kThreads, 0, r, d_n, n, d_r);
}

void count_visible_cuda(const int32_t* radii, int n, float* count) {
  HAHA_LAUNCH(count_visible_kernel, n, detail::kThreads, 0, radii, n, count);
}

void clamp01_cuda(float* x, int64_t n) { HAHA_LAUNCH(clamp01_kernel, n, detail::kThreads, 0, x, n); }

void count_nonfinite_cuda(const float* x, int64_t n, int32_t* counter) {
  HAHA_LAUNCH(nonfinite_kernel, n, detail::kThreads, 0, x, n, counter);
}

int32_t nonfinite_count(const DeviceBuffer<int32_t>& counter) {
  int32_t v = 0;
  counter.download(&v, 1);
  return v;
}

}  // namespace haha::cuda
