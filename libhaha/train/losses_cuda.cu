#include "train/losses_cuda.h"

#include "cuda/device_util.cuh"
#include "train/loss_kernels.h"

namespace haha::cuda {

namespace {

using detail::block_sum_atomic;
using detail::global_index;

// The SSIM window in float (the CPU path's T(g[k])), in constant memory: every thread of a
// blur reads the same tap at the same time.
__constant__ float c_taps[kSsimWindow];

void upload_taps() {
  float t[kSsimWindow];
  for (int k = 0; k < kSsimWindow; ++k) t[k] = float(loss::ssim_window().g[k]);
  HAHA_CUDA_CHECK(cudaMemcpyToSymbol(c_taps, t, sizeof t));
}

__global__ void weight_sum_kernel(const float* w, int64_t P, double* sum) {
  const int64_t p = global_index();
  block_sum_atomic(p < P ? double(w[p]) : 0.0, sum);
}

__global__ void l2_value_kernel(const float* x, const float* y, const float* w, int64_t P, double* sum) {
  const int64_t p = global_index();
  double s = 0.0;
  if (p < P) {
    const double wp = w ? double(w[p]) : 1.0;
    if (wp != 0.0) s = wp * loss::l2_pixel(x, y, p);
  }
  block_sum_atomic(s, sum);
}

__global__ void l2_grad_kernel(const float* x, const float* y, const float* w, int64_t P, float k, float* grad) {
  const int64_t p = global_index();
  if (p >= P) return;
  const float wp = w ? w[p] : 1.0f;
  if (wp == 0.0f) return;
  loss::l2_grad_pixel(x, y, p, k * wp, grad);
}

__global__ void ssim_maps_kernel(const float* x, const float* y, int c, int64_t P, float* t) {
  const int64_t p = global_index();
  if (p < P) loss::ssim_maps_pixel(x, y, c, P, p, t);
}

// n planes (H, W): element e = (plane * H + row) * W + x.
__global__ void blur_rows_kernel(const float* in, float* out, int H, int W, int n) {
  const int64_t e = global_index();
  if (e >= int64_t(n) * H * W) return;
  const int64_t row = e / W;
  const int x = int(e % W);
  loss::blur_row_span(in + row * W, W, x, x + 1, c_taps, out + row * W);
}

__global__ void blur_cols_kernel(const float* in, float* out, int H, int W, int n) {
  const int64_t e = global_index();
  const int64_t P = int64_t(H) * W;
  if (e >= int64_t(n) * P) return;
  const int64_t m = e / P;
  const int y = int((e % P) / W), x = int(e % W);
  loss::blur_col_span(in + m * P, H, W, y, x, x + 1, c_taps, out + m * P + int64_t(y) * W);
}

void blur(float* maps, float* tmp, int H, int W, int n) {
  const int64_t count = int64_t(n) * H * W;
  HAHA_LAUNCH(blur_rows_kernel, count, detail::kThreads, 0, maps, tmp, H, W, n);
  HAHA_LAUNCH(blur_cols_kernel, count, detail::kThreads, 0, tmp, maps, H, W, n);
}

__global__ void ssim_value_kernel(const float* t, const float* w, int64_t P, float gS, float* u, double* sum) {
  const int64_t p = global_index();
  double s = 0.0;
  if (p < P) {
    const float wp = w ? w[p] : 1.0f;
    const float S = loss::ssim_pixel(t, P, p, gS * wp, u);
    s = double(wp) * double(S);
  }
  block_sum_atomic(s, sum);
}

__global__ void ssim_grad_kernel(const float* x, const float* y, int c, int64_t P, const float* u, float grad_scale,
                                 float* grad) {
  const int64_t p = global_index();
  if (p < P) loss::ssim_grad_pixel(x, y, c, P, p, u, grad_scale, grad);
}

__global__ void luma_kernel(const float* x, const float* y, int64_t P, float* lx, float* ly) {
  const int64_t p = global_index();
  if (p >= P) return;
  lx[p] = loss::edge_luma(x, p);
  ly[p] = loss::edge_luma(y, p);
}

__global__ void edge_value_kernel(const float* lx, const float* ly, const float* w, int H, int W, float k, float* dgx,
                                  float* dgy, double* sum) {
  const int64_t p = global_index();
  double s = 0.0;
  if (p < int64_t(H) * W) {
    const float wp = w ? w[p] : 1.0f;
    s = loss::edge_pixel(lx, ly, H, W, int(p / W), int(p % W), wp, k, dgx, dgy);
  }
  block_sum_atomic(s, sum);
}

__global__ void edge_grad_kernel(const float* dgx, const float* dgy, int H, int W, float grad_scale, float* grad) {
  const int64_t p = global_index();
  if (p >= int64_t(H) * W) return;
  loss::edge_grad_pixel(p, grad_scale * loss::edge_gather(dgx, dgy, H, W, int(p / W), int(p % W)), grad);
}

// Weight sum as the CPU computes it (H W without weights); reads back when weighted.
double weight_sum(const float* weights, int H, int W, LossCudaScratch& s) {
  if (!weights) return double(H) * double(W);
  const int64_t P = int64_t(H) * W;
  s.sums.assign_zero(4);
  HAHA_LAUNCH(weight_sum_kernel, P, detail::kThreads, 0, weights, P, s.sums.data());
  double v = 0.0;
  s.sums.download(&v, 1);
  return v;
}

double read_sum(LossCudaScratch& s) {
  double v = 0.0;
  s.sums.download(&v, 1);
  return v;
}

__global__ void dice_sums_kernel(const float* p, const float* t, int64_t n, double* sums) {
  const int64_t i = global_index();
  const bool in = i < n;
  block_sum_atomic(in ? double(p[i]) * double(t[i]) : 0.0, sums);
  block_sum_atomic(in ? double(p[i]) + double(t[i]) : 0.0, sums + 1);
}

__global__ void dice_grad_kernel(const float* t, int64_t n, float a, float b, float* grad) {
  const int64_t i = global_index();
  if (i < n) loss::dice_grad_item(t, i, a, b, grad);
}

__global__ void tv_value_kernel(const float* tex, int H, int64_t rs, int C, double* sum) {
  const int64_t e = global_index();
  block_sum_atomic(e < int64_t(H) * rs ? loss::tv_value_item(tex, H, rs, C, e / rs, e % rs) : 0.0, sum);
}

__global__ void tv_grad_kernel(const float* tex, int H, int64_t rs, int C, float k, float* grad) {
  const int64_t e = global_index();
  if (e < int64_t(H) * rs) loss::tv_grad_item(tex, H, rs, C, e / rs, e % rs, k, grad);
}

__global__ void opacity_value_kernel(const float* o, int64_t n, OpacityRegMode mode, double* sum) {
  const int64_t i = global_index();
  block_sum_atomic(i < n ? loss::opacity_reg_value_item(o, i, mode) : 0.0, sum);
}

__global__ void opacity_grad_kernel(const float* o, int64_t n, OpacityRegMode mode, float k, float* grad) {
  const int64_t i = global_index();
  if (i < n) loss::opacity_reg_grad_item(o, i, mode, k, grad);
}

__global__ void stretch_value_kernel(const int32_t* face, const float* stretch, const float* offset, const float* scale,
                                     int64_t n, double* sum) {
  const int64_t i = global_index();
  block_sum_atomic(i < n ? loss::stretch_reg_value_item(face, stretch, offset, scale, i) : 0.0, sum);
}

__global__ void stretch_grad_kernel(const int32_t* face, const float* stretch, const float* offset, const float* scale,
                                    int64_t n, float k, float* grad_offset, float* grad_scale) {
  const int64_t i = global_index();
  if (i < n) loss::stretch_reg_grad_item(face, stretch, offset, scale, i, k, grad_offset, grad_scale);
}

}  // namespace

float dice_loss_cuda(const float* p, const float* t, int64_t n, LossCudaScratch& s, float* grad, float grad_scale) {
  s.sums.assign_zero(4);
  HAHA_LAUNCH(dice_sums_kernel, n, detail::kThreads, 0, p, t, n, s.sums.data());
  double h[2] = {0.0, 0.0};
  s.sums.download(h, 2);
  const double I = h[0], U = 1.0 + h[1];
  if (grad) {
    const float a = float(-2.0 / U) * grad_scale, b = float((2.0 * I + 1.0) / (U * U)) * grad_scale;
    HAHA_LAUNCH(dice_grad_kernel, n, detail::kThreads, 0, t, n, a, b, grad);
  }
  return float(1.0 - (2.0 * I + 1.0) / U);
}

float texture_tv_loss_cuda(const float* tex, int H, int W, int C, LossCudaScratch& s, float* grad, float grad_scale) {
  const double count = double(H) * W * C;
  if (!(count > 0.0)) return 0.0f;
  const int64_t rs = int64_t(W) * C, total = int64_t(H) * rs;
  s.sums.assign_zero(4);
  HAHA_LAUNCH(tv_value_kernel, total, detail::kThreads, 0, tex, H, rs, C, s.sums.data());
  if (grad) HAHA_LAUNCH(tv_grad_kernel, total, detail::kThreads, 0, tex, H, rs, C, float(1.0 / count) * grad_scale, grad);
  return float(read_sum(s) / count);
}

float opacity_reg_cuda(const float* o, int64_t n, OpacityRegMode mode, LossCudaScratch& s, float* grad,
                       float grad_scale) {
  if (n <= 0) return 0.0f;
  s.sums.assign_zero(4);
  HAHA_LAUNCH(opacity_value_kernel, n, detail::kThreads, 0, o, n, mode, s.sums.data());
  const bool sum_sq = mode == OpacityRegMode::SumSquares;
  if (grad)
    HAHA_LAUNCH(opacity_grad_kernel, n, detail::kThreads, 0, o, n, mode, sum_sq ? grad_scale : grad_scale / float(n),
                grad);
  const double v = read_sum(s);
  return float(sum_sq ? v : v / double(n));
}

float l2_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& s, const float* weights,
                   float* grad, float grad_scale) {
  const double denom = 3.0 * weight_sum(weights, H, W, s);
  if (!(denom > 0.0)) return 0.0f;
  const int64_t P = int64_t(H) * W;
  s.sums.assign_zero(4);
  HAHA_LAUNCH(l2_value_kernel, P, detail::kThreads, 0, x, y, weights, P, s.sums.data());
  if (grad) {
    const float k = float(2.0 / denom) * grad_scale;
    HAHA_LAUNCH(l2_grad_kernel, P, detail::kThreads, 0, x, y, weights, P, k, grad);
  }
  return float(read_sum(s) / denom);
}

float ssim_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& s, const float* weights,
                     float* grad, float grad_scale) {
  const double wsum = weight_sum(weights, H, W, s);
  if (!(wsum > 0.0) || H <= 0 || W <= 0) return 0.0f;
  const int64_t P = int64_t(H) * W;
  s.maps.resize(size_t(10 * P));
  float* t = s.maps.data();  // t[0..5P): maps, t[5P..10P): blur temporary / u
  float* u = t + 5 * P;
  upload_taps();
  const float gS = float(-1.0 / (3.0 * wsum));
  s.sums.assign_zero(4);
  for (int c = 0; c < 3; ++c) {
    HAHA_LAUNCH(ssim_maps_kernel, P, detail::kThreads, 0, x, y, c, P, t);
    blur(t, u, H, W, 5);
    HAHA_LAUNCH(ssim_value_kernel, P, detail::kThreads, 0, t, weights, P, gS, grad ? u : nullptr, s.sums.data());
    if (grad) {
      blur(u, t, H, W, 3);  // the blur is symmetric with zero padding: its own adjoint
      HAHA_LAUNCH(ssim_grad_kernel, P, detail::kThreads, 0, x, y, c, P, u, grad_scale, grad);
    }
  }
  return float(1.0 - read_sum(s) / (3.0 * wsum));
}

float edge_loss_cuda(const float* x, const float* y, int H, int W, LossCudaScratch& s, const float* weights,
                     float* grad, float grad_scale) {
  const double wsum = weight_sum(weights, H, W, s);
  if (!(wsum > 0.0) || H <= 0 || W <= 0) return 0.0f;
  const int64_t P = int64_t(H) * W;
  s.maps.resize(size_t(4 * P));
  float* lx = s.maps.data();
  float* ly = lx + P;
  float* dgx = lx + 2 * P;
  float* dgy = lx + 3 * P;
  HAHA_LAUNCH(luma_kernel, P, detail::kThreads, 0, x, y, P, lx, ly);
  const float k = float(1.0 / wsum);
  s.sums.assign_zero(4);
  HAHA_LAUNCH(edge_value_kernel, P, detail::kThreads, 0, lx, ly, weights, H, W, k, grad ? dgx : nullptr, dgy,
              s.sums.data());
  if (grad) HAHA_LAUNCH(edge_grad_kernel, P, detail::kThreads, 0, dgx, dgy, H, W, grad_scale, grad);
  return float(read_sum(s) / wsum);
}

float stretch_reg_cuda(const int32_t* face, const float* stretch, const float* offset, const float* scale, int64_t n,
                       LossCudaScratch& s, float* grad_offset, float* grad_scale, float grad_k) {
  if (n <= 0) return 0.0f;
  s.sums.assign_zero(4);
  HAHA_LAUNCH(stretch_value_kernel, n, detail::kThreads, 0, face, stretch, offset, scale, n, s.sums.data());
  if (grad_offset || grad_scale)
    HAHA_LAUNCH(stretch_grad_kernel, n, detail::kThreads, 0, face, stretch, offset, scale, n, grad_k / float(n),
                grad_offset, grad_scale);
  return float(read_sum(s) / double(n));
}

}  // namespace haha::cuda
