// Per-pixel / per-row / per-set kernels of the image losses and the KNN regulariser
// (train/losses.h), as HAHA_HD functions shared by the CPU launchers (losses.cpp) and the
// CUDA launchers (train/losses_cuda.cu, train/optim_cuda.cu). Value sums are returned per item
// in double; the launchers add them (in a fixed order on the CPU, by atomics on the GPU).
#pragma once

#include <cmath>
#include <cstdint>

#include "core/hd.h"
#include "train/losses.h"

namespace haha::loss {

template <class T>
HAHA_HD T sign_of(T v) {
  return v > T(0) ? T(1) : (v < T(0) ? T(-1) : T(0));
}

HAHA_HD int clamp_index(int v, int n) { return v < 0 ? 0 : (v >= n ? n - 1 : v); }

// ---- L2 ----
// sum_c (x - y)^2 of pixel p, in double.
template <class T>
HAHA_HD double l2_pixel(const T* x, const T* y, int64_t p) {
  double e = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double d = double(x[3 * p + c]) - double(y[3 * p + c]);
    e += d * d;
  }
  return e;
}
// grad[p] += k w (x - y), k = 2 grad_scale / (3 sum w).
template <class T>
HAHA_HD void l2_grad_pixel(const T* x, const T* y, int64_t p, T kw, T* grad) {
  for (int c = 0; c < 3; ++c) grad[3 * p + c] += kw * (x[3 * p + c] - y[3 * p + c]);
}

// ---- SSIM ----
inline constexpr int kSsimRadius = kSsimWindow / 2;

// The normalised 11-tap Gaussian window (host; launchers convert it to T once).
struct SsimWindowWeights {
  double g[kSsimWindow];
};
inline const SsimWindowWeights& ssim_window() {
  static const SsimWindowWeights w = [] {
    SsimWindowWeights k{};
    double s = 0.0;
    for (int i = 0; i < kSsimWindow; ++i) {
      const double d = i - kSsimWindow / 2;
      k.g[i] = std::exp(-d * d / (2.0 * kSsimSigma * kSsimSigma));
      s += k.g[i];
    }
    for (double& v : k.g) v /= s;
    return k;
  }();
  return w;
}

// Horizontal pass (zero padding) of one row a -> b over columns [x0, x1).
template <class T>
HAHA_HD void blur_row_span(const T* a, int W, int x0, int x1, const T* g, T* b) {
  constexpr int R = kSsimRadius;
  for (int x = x0; x < x1; ++x) {
    const int k0 = R - x > 0 ? R - x : 0, k1 = kSsimWindow < W - x + R ? kSsimWindow : W - x + R;
    T s = T(0);
    for (int k = k0; k < k1; ++k) s += g[k] * a[x + k - R];
    b[x] = s;
  }
}

// Vertical pass (zero padding) of one plane (H, W) into row y of out, columns [x0, x1).
template <class T>
HAHA_HD void blur_col_span(const T* plane, int H, int W, int y, int x0, int x1, const T* g, T* out_row) {
  constexpr int R = kSsimRadius;
  for (int x = x0; x < x1; ++x) out_row[x] = T(0);
  const int k0 = R - y > 0 ? R - y : 0, k1 = kSsimWindow < H - y + R ? kSsimWindow : H - y + R;
  for (int k = k0; k < k1; ++k) {
    const T gk = g[k];
    const T* src = plane + int64_t(y + k - R) * W;
    HAHA_SIMD
    for (int x = x0; x < x1; ++x) out_row[x] += gk * src[x];
  }
}

// The five maps of channel c at pixel p: x, y, x^2, y^2, xy (planes of P values in t).
template <class T>
HAHA_HD void ssim_maps_pixel(const T* x, const T* y, int c, int64_t P, int64_t p, T* t) {
  const T a = x[3 * p + c], b = y[3 * p + c];
  t[p] = a;
  t[P + p] = b;
  t[2 * P + p] = a * a;
  t[3 * P + p] = b * b;
  t[4 * P + p] = a * b;
}

// S at pixel p from the blurred maps t (mu_x, mu_y, E[x^2], E[y^2], E[xy]); with u given,
// writes dL/d(mu_x), dL/dE[x^2], dL/dE[xy] for dL/dS = gw (= -w / (3 sum w)) into the
// planes u, u + P, u + 2P.
template <class T>
HAHA_HD T ssim_pixel(const T* t, int64_t P, int64_t p, T gw, T* u) {
  const T C1 = T(kSsimC1), C2 = T(kSsimC2);
  const T m1 = t[p], m2 = t[P + p];
  const T A1 = T(2) * m1 * m2 + C1;
  const T A2 = T(2) * (t[4 * P + p] - m1 * m2) + C2;
  const T B1 = m1 * m1 + m2 * m2 + C1;
  const T B2 = (t[2 * P + p] - m1 * m1) + (t[3 * P + p] - m2 * m2) + C2;
  const T S = A1 * A2 / (B1 * B2);
  if (u) {
    u[p] = gw * ((T(2) * m2 * A2 - T(2) * m2 * A1) / (B1 * B2) - S * (T(2) * m1 / B1 - T(2) * m1 / B2));
    u[P + p] = gw * (-S / B2);
    u[2 * P + p] = gw * (T(2) * A1 / (B1 * B2));
  }
  return S;
}

// grad (channel c, pixel p) += grad_scale (blur(u0) + 2 x blur(u1) + y blur(u2)).
template <class T>
HAHA_HD void ssim_grad_pixel(const T* x, const T* y, int c, int64_t P, int64_t p, const T* u, T grad_scale, T* grad) {
  grad[3 * p + c] += grad_scale * (u[p] + T(2) * x[3 * p + c] * u[P + p] + y[3 * p + c] * u[2 * P + p]);
}

// ---- edge loss ----
template <class T>
HAHA_HD T edge_luma(const T* img, int64_t p) {
  return T(kEdgeLumR) * img[3 * p] + T(kEdgeLumG) * img[3 * p + 1] + T(kEdgeLumB) * img[3 * p + 2];
}

// w |m_x - m_y| at pixel (r, c) in double; with dgx / dgy given, writes dL/dgx, dL/dgy of the
// render there (k = 1 / sum w).
template <class T>
HAHA_HD double edge_pixel(const T* lx, const T* ly, int H, int W, int r, int c, T w, T k, T* dgx, T* dgy) {
  const T eps = T(kEdgeEps);
  const int64_t up = int64_t(clamp_index(r - 1, H)) * W, dn = int64_t(clamp_index(r + 1, H)) * W,
                row = int64_t(r) * W;
  const int cm = clamp_index(c - 1, W), cp = clamp_index(c + 1, W);
  const T gxx = lx[row + cp] - lx[row + cm], gyx = lx[dn + c] - lx[up + c];
  const T gxy = ly[row + cp] - ly[row + cm], gyy = ly[dn + c] - ly[up + c];
  const T mx = std::sqrt(gxx * gxx + gyx * gyx + eps);
  const T my = std::sqrt(gxy * gxy + gyy * gyy + eps);
  if (dgx) {
    const T d = k * w * sign_of(mx - my) / mx;
    dgx[row + c] = d * gxx;
    dgy[row + c] = d * gyx;
  }
  return double(w) * std::abs(double(mx) - double(my));
}

// dL/dluma at (r, c): gathers +dg from the pixels whose "+1" neighbour clamps onto it and
// -dg from those whose "-1" neighbour does (candidates: the 3 neighbours).
template <class T>
HAHA_HD T edge_gather(const T* dgx, const T* dgy, int H, int W, int r, int c) {
  T dl = T(0);
  for (int q = c - 1; q <= c + 1; ++q) {
    if (q < 0 || q >= W) continue;
    if (clamp_index(q + 1, W) == c) dl += dgx[int64_t(r) * W + q];
    if (clamp_index(q - 1, W) == c) dl -= dgx[int64_t(r) * W + q];
  }
  for (int q = r - 1; q <= r + 1; ++q) {
    if (q < 0 || q >= H) continue;
    if (clamp_index(q + 1, H) == r) dl += dgy[int64_t(q) * W + c];
    if (clamp_index(q - 1, H) == r) dl -= dgy[int64_t(q) * W + c];
  }
  return dl;
}

template <class T>
HAHA_HD void edge_grad_pixel(int64_t p, T dl, T* grad) {
  grad[3 * p] += T(kEdgeLumR) * dl;
  grad[3 * p + 1] += T(kEdgeLumG) * dl;
  grad[3 * p + 2] += T(kEdgeLumB) * dl;
}

// ---- Dice, texture TV, opacity regulariser (per element) ----
// Dice: grad[i] += a t[i] + b with a = -2 s / U, b = s (2 I + 1) / U^2 (losses.cpp).
template <class T>
HAHA_HD void dice_grad_item(const T* t, int64_t i, T a, T b, T* grad) {
  grad[i] += a * t[i] + b;
}

// TV of element i of row r (row stride rs = W C): |right difference| + |down difference|,
// each present when the neighbour exists (double).
template <class T>
HAHA_HD double tv_value_item(const T* tex, int H, int64_t rs, int C, int64_t r, int64_t i) {
  const T* a = tex + r * rs;
  double s = 0.0;
  if (i >= C) s += std::abs(double(a[i]) - double(a[i - C]));
  if (r + 1 < H) s += std::abs(double(a[i + rs]) - double(a[i]));
  return s;
}
// Its gradient at element i of row r (every difference it takes part in), times k.
template <class T>
HAHA_HD void tv_grad_item(const T* tex, int H, int64_t rs, int C, int64_t r, int64_t i, T k, T* grad) {
  const T* a = tex + r * rs;
  T d = T(0);
  if (i >= C) d += sign_of(a[i] - a[i - C]);
  if (i + C < rs) d -= sign_of(a[i + C] - a[i]);
  if (r > 0) d += sign_of(a[i] - a[i - rs]);
  if (r + 1 < H) d -= sign_of(a[i + rs] - a[i]);
  grad[r * rs + i] += k * d;
}

// Opacity regulariser: the value of element i (double) and its gradient.
template <class T>
HAHA_HD double opacity_reg_value_item(const T* o, int64_t i, OpacityRegMode mode) {
  return mode == OpacityRegMode::SumSquares ? double(o[i]) * double(o[i]) : std::abs(double(o[i]));
}
// k = grad_scale (SumSquares) or grad_scale / n (MeanAbs).
template <class T>
HAHA_HD void opacity_reg_grad_item(const T* o, int64_t i, OpacityRegMode mode, T k, T* grad) {
  grad[i] += mode == OpacityRegMode::SumSquares ? k * T(2) * o[i] : k * sign_of(o[i]);
}

// Stretch regulariser: Gaussian i's value (double) and its gradient; k = grad_k / n.
template <class T>
HAHA_HD double stretch_reg_value_item(const int32_t* face, const float* stretch, const T* offset, const T* scale,
                                      int64_t i) {
  const double w = stretch[face[i]];
  double v = 0.0;
  for (int c = 0; c < 3; ++c) v += double(offset[3 * i + c]) * double(offset[3 * i + c]) + double(scale[3 * i + c]) * double(scale[3 * i + c]);
  return w * v;
}
template <class T>
HAHA_HD void stretch_reg_grad_item(const int32_t* face, const float* stretch, const T* offset, const T* scale,
                                   int64_t i, T k, T* grad_offset, T* grad_scale) {
  const T w = T(2) * k * T(stretch[face[i]]);
  for (int c = 0; c < 3; ++c) {
    if (grad_offset) grad_offset[3 * i + c] += w * offset[3 * i + c];
    if (grad_scale) grad_scale[3 * i + c] += w * scale[3 * i + c];
  }
}

// ---- KNN regulariser ----
// Members of set i: the entries of row (K values) in [0, n), in row order.
HAHA_HD bool knn_member(int32_t j, int64_t n) { return j >= 0 && j < n; }

// coef * mean_d std_{j in set} v_j[d] (value, double) and its gradient, scattered through
// `add` into the members' rows of grad (may be null). m = number of members.
template <class T, class Add = PlainAdd>
HAHA_HD double knn_set_std(const T* v, int D, const int32_t* row, int K, int64_t n, int m, double coef, T* grad,
                           double gscale, Add add = {}) {
  if (!v || m < 2 || coef == 0.0) return 0.0;
  const double sq_eps = std::sqrt(kKnnStdEps);
  int first_j = -1;
  for (int k = 0; k < K && first_j < 0; ++k)
    if (knn_member(row[k], n)) first_j = row[k];
  double total = 0.0;
  for (int d = 0; d < D; ++d) {
    // Mean as first + mean offset: exact (deviations exactly 0) when the values are equal.
    const double first = double(v[int64_t(first_j) * D + d]);
    double mean = 0.0;
    for (int k = 0; k < K; ++k)
      if (knn_member(row[k], n)) mean += double(v[int64_t(row[k]) * D + d]) - first;
    mean = first + mean / m;
    double var = 0.0;
    for (int k = 0; k < K; ++k)
      if (knn_member(row[k], n)) {
        const double e = double(v[int64_t(row[k]) * D + d]) - mean;
        var += e * e;
      }
    var /= (m - 1);
    const double sd = std::sqrt(var + kKnnStdEps);
    total += sd - sq_eps;
    if (grad) {
      const double kk = gscale * coef / D / ((m - 1) * sd);
      for (int k = 0; k < K; ++k)
        if (knn_member(row[k], n)) {
          const int64_t q = int64_t(row[k]) * D + d;
          add(&grad[q], T(kk * (double(v[q]) - mean)));
        }
    }
  }
  return coef * total / D;
}

// All terms of set i (value, double); gradients scattered through `add`.
template <class T, class Add = PlainAdd>
HAHA_HD double knn_reg_item(const KnnRegInputs<T>& in, const int32_t* sets, int K, const KnnRegWeights& w,
                            const KnnRegGrads<T>& g, double gs, int64_t i, Add add = {}) {
  const int64_t n = in.n;
  const double per_set = 1.0 / double(n), per_pair = w.distance / (double(n) * K);
  const int32_t* row = sets + i * K;
  int m = 0;
  for (int k = 0; k < K; ++k) m += knn_member(row[k], n);  // out-of-range entries count as absent
  double total = 0.0;
  total += knn_set_std(in.rotation, 4, row, K, n, m, w.rotation * per_set, g.rotation, gs, add);
  total += knn_set_std(in.scale, 3, row, K, n, m, w.scale * per_set, g.scale, gs, add);
  total += knn_set_std(in.opacity, 1, row, K, n, m, w.opacity * per_set, g.opacity, gs, add);
  total += knn_set_std(in.color, 3, row, K, n, m, w.color * per_set, g.color, gs, add);
  if (in.position && per_pair != 0.0) {
    const T* p = in.position;
    for (int k = 0; k < K; ++k) {
      if (!knn_member(row[k], n)) continue;
      const int64_t j = row[k];
      double d2 = 0.0;
      for (int a = 0; a < 3; ++a) {
        const double e = double(p[3 * i + a]) - double(p[3 * j + a]);
        d2 += e * e;
        if (g.position) {
          const T ge = T(2.0 * per_pair * gs * e);
          add(&g.position[3 * i + a], ge);
          add(&g.position[3 * j + a], -ge);
        }
      }
      total += per_pair * d2;
    }
  }
  return total;
}

}  // namespace haha::loss
