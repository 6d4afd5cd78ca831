#include "train/losses.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.h"
#include "train/loss_kernels.h"

namespace haha {
namespace {

constexpr int64_t kChunk = 4096;

// Loops of fewer than ~1M scalar operations (cost = n * per_item) run serially: an
// OpenMP region costs microseconds, milliseconds when other processes hold the cores.
template <class F>
void par_for(int64_t n, int64_t per_item, F&& f) {
  if (n * per_item < (int64_t(1) << 20)) {
    for (int64_t i = 0; i < n; ++i) f(i);
  } else {
    parallel_for(n, f);
  }
}

// Sum of f(i) for i in [0, n): parallel, but added in index order so the value is the
// same for every thread count.
template <class F>
double ordered_sum(int64_t n, int64_t per_item, F&& f) {
  if (n <= 0) return 0.0;
  std::vector<double> part(size_t(n), 0.0);
  par_for(n, per_item, [&](int64_t i) { part[size_t(i)] = f(i); });
  double s = 0.0;
  for (double v : part) s += v;
  return s;
}

// Same over [0, n) in chunks of kChunk elements; f(begin, end) returns the chunk's sum.
template <class F>
double chunked_sum(int64_t n, F&& f) {
  const int64_t chunks = (n + kChunk - 1) / kChunk;
  return ordered_sum(chunks, kChunk, [&](int64_t c) { return f(c * kChunk, std::min(n, (c + 1) * kChunk)); });
}


template <class T>
double weight_sum(const T* weights, int H, int W) {
  if (!weights) return double(H) * double(W);
  return ordered_sum(H, W, [&](int64_t y) {
    double s = 0.0;
    for (int x = 0; x < W; ++x) s += double(weights[y * W + x]);
    return s;
  });
}

// ---- separable Gaussian blur (zero padding), symmetric so it is its own adjoint ------

// The window in the image type, converted once (T(g[k]) as every use did).
template <class T>
struct SsimTaps {
  T g[kSsimWindow];
  SsimTaps() {
    for (int k = 0; k < kSsimWindow; ++k) g[k] = T(loss::ssim_window().g[k]);
  }
};

// `n` planes of H x W, consecutive in memory: horizontal pass in -> out.
template <class T>
void blur_rows(const T* in, T* out, int H, int W, int n) {
  const SsimTaps<T> taps;
  constexpr int R = loss::kSsimRadius;
  par_for(int64_t(n) * H, int64_t(W) * kSsimWindow, [&](int64_t row) {
    const T* a = in + row * W;
    T* b = out + row * W;
    if (W <= 2 * R) return loss::blur_row_span(a, W, 0, W, taps.g, b);
    loss::blur_row_span(a, W, 0, R, taps.g, b);
    loss::blur_row_span(a, W, W - R, W, taps.g, b);
    // The columns whose window lies inside the row, tap by tap so the loop over x
    // vectorises: blur_row_span's sums, in its order.
    for (int x = R; x < W - R; ++x) b[x] = T(0);
    for (int k = 0; k < kSsimWindow; ++k) {
      const T gk = taps.g[k];
      const T* src = a + k - R;
      HAHA_SIMD
      for (int x = R; x < W - R; ++x) b[x] += gk * src[x];
    }
  });
}

// Vertical pass; the inner loop runs along a row so it vectorises.
template <class T>
void blur_cols(const T* in, T* out, int H, int W, int n) {
  const SsimTaps<T> taps;
  const int64_t P = int64_t(H) * W;
  par_for(int64_t(n) * H, int64_t(W) * kSsimWindow, [&](int64_t row) {
    const int64_t m = row / H;
    const int y = int(row % H);
    loss::blur_col_span(in + m * P, H, W, y, 0, W, taps.g, out + m * P + int64_t(y) * W);
  });
}

template <class T>
void blur(T* maps, T* tmp, int H, int W, int n) {  // maps -> maps, via tmp
  blur_rows(maps, tmp, H, W, n);
  blur_cols(tmp, maps, H, W, n);
}

}  // namespace

// ---- L2 ---------------------------------------------------------------------------------

template <class T>
T l2_loss(const T* x, const T* y, int H, int W, const T* weights, T* grad, T grad_scale) {
  const double denom = 3.0 * weight_sum(weights, H, W);
  if (!(denom > 0.0)) return T(0);
  const double sum = ordered_sum(H, 4 * W, [&](int64_t r) {
    double s = 0.0;
    for (int64_t p = r * W; p < (r + 1) * W; ++p) {
      const double w = weights ? double(weights[p]) : 1.0;
      if (w == 0.0) continue;
      s += w * loss::l2_pixel(x, y, p);
    }
    return s;
  });
  if (grad) {
    const T k = T(2.0 / denom) * grad_scale;
    par_for(int64_t(H) * W, 4, [&](int64_t p) {
      const T w = weights ? weights[p] : T(1);
      if (w == T(0)) return;
      loss::l2_grad_pixel(x, y, p, k * w, grad);
    });
  }
  return T(sum / denom);
}

// ---- SSIM ---------------------------------------------------------------------------------

template <class T>
T ssim_loss(const T* x, const T* y, int H, int W, LossScratch<T>& scratch, const T* weights, T* grad,
            T grad_scale) {
  const double wsum = weight_sum(weights, H, W);
  if (!(wsum > 0.0) || H <= 0 || W <= 0) return T(0);
  const int64_t P = int64_t(H) * W;
  T* t = scratch.get(size_t(10 * P));  // t[0..5P): maps, t[5P..10P): blur temporary
  T* u = t + 5 * P;
  const T gS = T(-1.0 / (3.0 * wsum));  // dL/dS for a pixel of weight 1
  double total = 0.0;
  for (int c = 0; c < 3; ++c) {
    par_for(P, 5, [&](int64_t p) { loss::ssim_maps_pixel(x, y, c, P, p, t); });
    blur(t, u, H, W, 5);  // t: mu_x, mu_y, E[x^2], E[y^2], E[xy]
    total += ordered_sum(H, 30 * int64_t(W), [&](int64_t r) {
      double s = 0.0;
      for (int64_t p = r * W; p < (r + 1) * W; ++p) {
        const T w = weights ? weights[p] : T(1);
        // dL/d(mu_x), dL/dE[x^2], dL/dE[xy] at this pixel go into u when a gradient is wanted
        const T S = loss::ssim_pixel(t, P, p, gS * w, grad ? u : static_cast<T*>(nullptr));
        s += double(w) * double(S);
      }
      return s;
    });
    if (grad) {
      blur(u, t, H, W, 3);  // the blur is symmetric with zero padding: its own adjoint
      par_for(P, 4, [&](int64_t p) { loss::ssim_grad_pixel(x, y, c, P, p, u, grad_scale, grad); });
    }
  }
  return T(1.0 - total / (3.0 * wsum));
}

double ssim_metric(const float* x, const float* y, int H, int W, bool valid_only) {
  const int64_t P = int64_t(H) * W;
  std::vector<double> xd(x, x + 3 * P), yd(y, y + 3 * P), w;
  constexpr int R = kSsimWindow / 2;
  if (valid_only && H >= kSsimWindow && W >= kSsimWindow) {
    w.assign(size_t(P), 0.0);
    for (int r = R; r < H - R; ++r)
      for (int c = R; c < W - R; ++c) w[size_t(r) * W + c] = 1.0;
  }
  LossScratch<double> scratch;
  return 1.0 - ssim_loss<double>(xd.data(), yd.data(), H, W, scratch, w.empty() ? nullptr : w.data());
}

double psnr(const float* x, const float* y, int H, int W, const float* weights) {
  const double denom = 3.0 * weight_sum(weights, H, W);
  if (!(denom > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double sum = ordered_sum(H, 4 * W, [&](int64_t r) {
    double s = 0.0;
    for (int64_t p = r * W; p < (r + 1) * W; ++p) {
      const double w = weights ? double(weights[p]) : 1.0;
      for (int c = 0; c < 3; ++c) {
        const double d = double(x[3 * p + c]) - double(y[3 * p + c]);
        s += w * d * d;
      }
    }
    return s;
  });
  const double mse = sum / denom;
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return -10.0 * std::log10(mse);
}

// ---- edge loss ------------------------------------------------------------------------------

template <class T>
T edge_loss(const T* x, const T* y, int H, int W, LossScratch<T>& scratch, const T* weights, T* grad,
            T grad_scale) {
  const double wsum = weight_sum(weights, H, W);
  if (!(wsum > 0.0) || H <= 0 || W <= 0) return T(0);
  const int64_t P = int64_t(H) * W;
  T* lx = scratch.get(size_t(4 * P));
  T* ly = lx + P;
  T* dgx = lx + 2 * P;
  T* dgy = lx + 3 * P;
  par_for(P, 6, [&](int64_t p) {
    lx[p] = loss::edge_luma(x, p);
    ly[p] = loss::edge_luma(y, p);
  });
  const T k = T(1.0 / wsum);
  const double sum = ordered_sum(H, 20 * int64_t(W), [&](int64_t r64) {
    const int r = int(r64);
    double s = 0.0;
    for (int c = 0; c < W; ++c) {
      const T w = weights ? weights[int64_t(r) * W + c] : T(1);
      s += loss::edge_pixel(lx, ly, H, W, r, c, w, k, grad ? dgx : static_cast<T*>(nullptr), dgy);
    }
    return s;
  });
  if (grad) {
    par_for(H, 20 * int64_t(W), [&](int64_t r64) {
      const int r = int(r64);
      for (int c = 0; c < W; ++c)
        loss::edge_grad_pixel(int64_t(r) * W + c, grad_scale * loss::edge_gather(dgx, dgy, H, W, r, c), grad);
    });
  }
  return T(sum / wsum);
}

// ---- Dice -------------------------------------------------------------------------------------

template <class T>
T dice_loss(const T* p, const T* t, int64_t n, T* grad, T grad_scale) {
  const double I = chunked_sum(n, [&](int64_t b, int64_t e) {
    double s = 0.0;
    for (int64_t i = b; i < e; ++i) s += double(p[i]) * double(t[i]);
    return s;
  });
  const double U = 1.0 + chunked_sum(n, [&](int64_t b, int64_t e) {
                     double s = 0.0;
                     for (int64_t i = b; i < e; ++i) s += double(p[i]) + double(t[i]);
                     return s;
                   });
  if (grad) {
    const T a = T(-2.0 / U) * grad_scale, b = T((2.0 * I + 1.0) / (U * U)) * grad_scale;
    par_for(n, 2, [&](int64_t i) { loss::dice_grad_item(t, i, a, b, grad); });
  }
  return T(1.0 - (2.0 * I + 1.0) / U);
}

// ---- texture TV ---------------------------------------------------------------------------------

template <class T>
T texture_tv_loss(const T* tex, int H, int W, int C, T* grad, T grad_scale) {
  const double count = double(H) * W * C;
  if (!(count > 0.0)) return T(0);
  const int64_t rs = int64_t(W) * C;  // row stride
  const double sum = ordered_sum(H, 4 * rs, [&](int64_t r) {
    double s = 0.0;
    const T* a = tex + r * rs;
    for (int64_t i = C; i < rs; ++i) s += std::abs(double(a[i]) - double(a[i - C]));
    if (r + 1 < H)
      for (int64_t i = 0; i < rs; ++i) s += std::abs(double(a[i + rs]) - double(a[i]));
    return s;
  });
  if (grad) {
    const T k = T(1.0 / count) * grad_scale;
    par_for(H, 8 * rs, [&](int64_t r) {
      if (r == 0 || r + 1 >= H || rs <= 2 * int64_t(C)) {
        for (int64_t i = 0; i < rs; ++i) loss::tv_grad_item(tex, H, rs, C, r, i, k, grad);
        return;
      }
      for (int64_t i = 0; i < C; ++i) loss::tv_grad_item(tex, H, rs, C, r, i, k, grad);
      for (int64_t i = rs - C; i < rs; ++i) loss::tv_grad_item(tex, H, rs, C, r, i, k, grad);
      // Inside the texture all four neighbours exist: tv_grad_item's value with the signs
      // summed as integers, without branches, so the loop vectorises. Same result: the sum
      // of four signs is an exact small integer either way.
      const T* a = tex + r * rs;
      T* gr = grad + r * rs;
      HAHA_SIMD
      for (int64_t i = C; i < rs - C; ++i) {
        const T d0 = a[i] - a[i - C], d1 = a[i + C] - a[i], d2 = a[i] - a[i - rs], d3 = a[i + rs] - a[i];
        const int s = (d0 > T(0)) - (d0 < T(0)) - (d1 > T(0)) + (d1 < T(0)) + (d2 > T(0)) - (d2 < T(0)) -
                      (d3 > T(0)) + (d3 < T(0));
        gr[i] += k * T(s);
      }
    });
  }
  return T(sum / count);
}

// ---- opacity regulariser -----------------------------------------------------------------------

template <class T>
T opacity_reg(const T* o, int64_t n, OpacityRegMode mode, T* grad, T grad_scale) {
  if (n <= 0) return T(0);
  if (mode == OpacityRegMode::SumSquares) {
    const double s = chunked_sum(n, [&](int64_t b, int64_t e) {
      double v = 0.0;
      for (int64_t i = b; i < e; ++i) v += double(o[i]) * double(o[i]);
      return v;
    });
    if (grad) par_for(n, 2, [&](int64_t i) { loss::opacity_reg_grad_item(o, i, mode, grad_scale, grad); });
    return T(s);
  }
  const double s = chunked_sum(n, [&](int64_t b, int64_t e) {
    double v = 0.0;
    for (int64_t i = b; i < e; ++i) v += std::abs(double(o[i]));
    return v;
  });
  if (grad) {
    const T k = grad_scale / T(n);
    par_for(n, 2, [&](int64_t i) { loss::opacity_reg_grad_item(o, i, mode, k, grad); });
  }
  return T(s / double(n));
}

// ---- Stretch regulariser -------------------------------------------------------------------------

template <class T>
T stretch_reg(const int32_t* face, const float* stretch, const T* offset, const T* scale, int64_t n, T* grad_offset,
              T* grad_scale, T grad_k) {
  if (n <= 0) return T(0);
  const double s = chunked_sum(n, [&](int64_t b, int64_t e) {
    double v = 0.0;
    for (int64_t i = b; i < e; ++i) v += loss::stretch_reg_value_item(face, stretch, offset, scale, i);
    return v;
  });
  if (grad_offset || grad_scale) {
    const T k = grad_k / T(n);
    par_for(n, 2, [&](int64_t i) { loss::stretch_reg_grad_item(face, stretch, offset, scale, i, k, grad_offset, grad_scale); });
  }
  return T(s / double(n));
}

// ---- KNN regulariser -----------------------------------------------------------------------------

template <class T>
T knn_reg(const KnnRegInputs<T>& in, const int32_t* sets, int K, const KnnRegWeights& w,
          const KnnRegGrads<T>* grads, T grad_scale) {
  const int64_t n = in.n;
  if (n <= 0 || K <= 0) return T(0);
  const KnnRegGrads<T> g = grads ? *grads : KnnRegGrads<T>{};
  // Serial: each set scatters into its members' gradients, and the cost (n K 14 flops)
  // is small next to rendering; the order is fixed, so the result is deterministic.
  double total = 0.0;
  for (int64_t i = 0; i < n; ++i) total += loss::knn_reg_item(in, sets, K, w, g, double(grad_scale), i);
  return T(total);
}

// ---- instantiations ----------------------------------------------------------------------------------

#define HAHA_LOSSES_INSTANTIATE(T)                                                                       \
  template T l2_loss<T>(const T*, const T*, int, int, const T*, T*, T);                                 \
  template T ssim_loss<T>(const T*, const T*, int, int, LossScratch<T>&, const T*, T*, T);              \
  template T edge_loss<T>(const T*, const T*, int, int, LossScratch<T>&, const T*, T*, T);              \
  template T dice_loss<T>(const T*, const T*, int64_t, T*, T);                                           \
  template T texture_tv_loss<T>(const T*, int, int, int, T*, T);                                         \
  template T opacity_reg<T>(const T*, int64_t, OpacityRegMode, T*, T);                                   \
  template T stretch_reg<T>(const int32_t*, const float*, const T*, const T*, int64_t, T*, T*, T);       \
  template T knn_reg<T>(const KnnRegInputs<T>&, const int32_t*, int, const KnnRegWeights&,              \
                        const KnnRegGrads<T>*, T);
HAHA_LOSSES_INSTANTIATE(float)
HAHA_LOSSES_INSTANTIATE(double)
#undef HAHA_LOSSES_INSTANTIATE

}  // namespace haha
