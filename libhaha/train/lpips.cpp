#include "train/lpips.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/parallel.h"

namespace haha {
namespace {

constexpr double kNormEps = 1e-10;  // lpips normalize_tensor
constexpr double kShift[3] = {-.030, -.088, -.188};
constexpr double kScale[3] = {.458, .448, .450};

// Architecture table: 'C' conv + ReLU (features index, stride, pad), 'P' max-pool (k, s),
// 'T' tap (the current activation feeds the next linear head).
struct Item {
  char kind;
  int a = 0, b = 0, c = 0;
};
std::vector<Item> architecture(LpipsBackbone bb) {
  if (bb == LpipsBackbone::Alex)
    return {{'C', 0, 4, 2}, {'T'}, {'P', 3, 2}, {'C', 3, 1, 2}, {'T'}, {'P', 3, 2}, {'C', 6, 1, 1}, {'T'},
            {'C', 8, 1, 1}, {'T'}, {'C', 10, 1, 1}, {'T'}};
  return {{'C', 0, 1, 1},  {'C', 2, 1, 1},  {'T'},          {'P', 2, 2},    {'C', 5, 1, 1},  {'C', 7, 1, 1},
          {'T'},           {'P', 2, 2},     {'C', 10, 1, 1}, {'C', 12, 1, 1}, {'C', 14, 1, 1}, {'T'},
          {'P', 2, 2},     {'C', 17, 1, 1}, {'C', 19, 1, 1}, {'C', 21, 1, 1}, {'T'},          {'P', 2, 2},
          {'C', 24, 1, 1}, {'C', 26, 1, 1}, {'C', 28, 1, 1}, {'T'}};
}

std::string shape_str(const std::vector<int64_t>& s) {
  std::string r = "(";
  for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + (s.size() == 1 ? ",)" : ")");
}

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

// Output index range [lo, hi) whose input position o*s + k - p lies in [0, n).
inline void valid_range(int n_in, int n_out, int k, int s, int p, int& lo, int& hi) {
  const int a = p - k;
  lo = a > 0 ? (a + s - 1) / s : 0;
  const int b = n_in - 1 + p - k;
  hi = b < 0 ? 0 : std::min(n_out, b / s + 1);
}

// Zero-padded copy of C planes (H, W): pad on every side plus kExtra zeros on the right,
// so the blocked kernel reads whole 8-wide chunks without bounds checks.
constexpr int kBlockX = 8;
template <class T>
void pad_planes(const T* in, int C, int H, int W, int pad, std::vector<T>& out, int& Hp, int& Wp) {
  Hp = H + 2 * pad;
  Wp = W + 2 * pad + kBlockX;
  out.assign(size_t(C) * Hp * Wp, T(0));
  for (int c = 0; c < C; ++c)
    for (int y = 0; y < H; ++y)
      std::copy_n(in + (int64_t(c) * H + y) * W, W, out.data() + (int64_t(c) * Hp + y + pad) * Wp + pad);
}

// Stride-1 convolution of padded planes, a block of NO output channels by 8 output
// columns held in registers while the (c, ky, kx) sum runs: each input value loaded
// feeds NO multiply-adds. w is (O, C, kh, kw); out (O, Ho, Wo) is overwritten, or added
// to when `add` (then no bias / ReLU).
template <class T, int NO>
void conv_block(const T* in, int C, int Hp, int Wp, const T* w, int kh, int kw, const T* bias, bool relu, bool add,
                int o0, int oy, T* out, int Ho, int Wo) {
  // GCC vector extension of the target's native 16 bytes, NV of them per 8 columns: the
  // NO x NV accumulators stay in registers (wider vectors or a plain array went to memory).
  typedef T V __attribute__((vector_size(16)));
  constexpr int L = int(16 / sizeof(T)), NV = kBlockX / L;
  const int64_t plane = int64_t(Hp) * Wp, wo = int64_t(C) * kh * kw;
  for (int ox = 0; ox < Wo; ox += kBlockX) {
    V acc[NO][NV];
#pragma GCC unroll 8
    for (int q = 0; q < NO; ++q)
#pragma GCC unroll 8
      for (int u = 0; u < NV; ++u) acc[q][u] = V{} + (bias ? bias[o0 + q] : T(0));
    for (int c = 0; c < C; ++c)
      for (int ky = 0; ky < kh; ++ky) {
        const T* src = in + c * plane + int64_t(oy + ky) * Wp + ox;
        const T* wk = w + (int64_t(o0) * C + c) * kh * kw + ky * kw;
        for (int kx = 0; kx < kw; ++kx) {
          V v[NV];
#pragma GCC unroll 8
          for (int u = 0; u < NV; ++u) std::memcpy(&v[u], src + kx + u * L, sizeof(V));
#pragma GCC unroll 8
          for (int q = 0; q < NO; ++q) {
            const T wq = wk[q * wo + kx];
#pragma GCC unroll 8
            for (int u = 0; u < NV; ++u) acc[q][u] += wq * v[u];
          }
        }
      }
    const int n = std::min(kBlockX, Wo - ox);
    for (int q = 0; q < NO; ++q) {
      T r[kBlockX];
      std::memcpy(r, &acc[q][0], sizeof(r));
      T* d = out + (int64_t(o0 + q) * Ho + oy) * Wo + ox;
      for (int j = 0; j < n; ++j) d[j] = add ? d[j] + r[j] : (relu ? std::max(r[j], T(0)) : r[j]);
    }
  }
}

template <class T>
void conv_s1(const T* padded, int C, int Hp, int Wp, const T* w, int O, int kh, int kw, const T* bias, bool relu,
             bool add, T* out, int Ho, int Wo) {
  constexpr int NO = 4;
  const int blocks = (O + NO - 1) / NO;
  par_for(int64_t(blocks) * Ho, int64_t(NO) * C * kh * kw * Wo, [&](int64_t item) {
    const int b = int(item / Ho), oy = int(item % Ho), o0 = b * NO;
    if (o0 + NO <= O) {
      conv_block<T, NO>(padded, C, Hp, Wp, w, kh, kw, bias, relu, add, o0, oy, out, Ho, Wo);
    } else {
      for (int o = o0; o < O; ++o)
        conv_block<T, 1>(padded, C, Hp, Wp, w, kh, kw, bias, relu, add, o, oy, out, Ho, Wo);
    }
  });
}

}  // namespace

template <class T>
LpipsNet<T>::LpipsNet(const LpipsWeights& weights, LpipsBackbone backbone)
    : backbone_(backbone), source_(weights.source) {
  const std::string prefix = lpips_prefix(backbone);
  const std::string where = weights.source.empty() ? std::string("lpips weights") : weights.source;
  auto get = [&](const std::string& key) -> const LpipsTensor& {
    auto it = weights.tensors.find(key);
    if (it == weights.tensors.end()) fail(where, key + ": missing (LPIPS " + prefix + " layout, see train/lpips.h)");
    int64_t count = 1;
    for (int64_t d : it->second.shape) count *= d;
    if (count != int64_t(it->second.data.size()))
      fail(where, key + ": shape " + shape_str(it->second.shape) + " does not match its " +
                      std::to_string(it->second.data.size()) + " values");
    return it->second;
  };
  int channels = 3;
  for (const Item& item : architecture(backbone)) {
    if (item.kind == 'C') {
      const std::string key = prefix + ".features." + std::to_string(item.a);
      const LpipsTensor& w = get(key + ".weight");
      if (w.shape.size() != 4 || w.shape[0] < 1 || w.shape[1] != channels || w.shape[2] < 1 || w.shape[3] < 1)
        fail(where, key + ".weight: expected shape (out, " + std::to_string(channels) + ", kh, kw), got " +
                        shape_str(w.shape));
      const LpipsTensor& b = get(key + ".bias");
      if (b.shape != std::vector<int64_t>{w.shape[0]})
        fail(where, key + ".bias: expected shape (" + std::to_string(w.shape[0]) + ",), got " + shape_str(b.shape));
      Conv cv;
      cv.out = int(w.shape[0]);
      cv.in = channels;
      cv.kh = int(w.shape[2]);
      cv.kw = int(w.shape[3]);
      cv.stride = item.b;
      cv.pad = item.c;
      cv.w.assign(w.data.begin(), w.data.end());
      cv.b.assign(b.data.begin(), b.data.end());
      if (cv.stride == 1 && cv.pad < cv.kh && cv.pad < cv.kw) {
        // The input gradient of a stride-1 conv is a stride-1 conv of the output gradient
        // (padding k - 1 - pad) with the kernels flipped and in/out swapped.
        cv.wt.resize(cv.w.size());
        const int kk = cv.kh * cv.kw;
        for (int o = 0; o < cv.out; ++o)
          for (int c = 0; c < cv.in; ++c)
            for (int t = 0; t < kk; ++t)
              cv.wt[(size_t(c) * cv.out + o) * kk + (kk - 1 - t)] = cv.w[(size_t(o) * cv.in + c) * kk + t];
      }
      convs_.push_back(std::move(cv));
      ops_.push_back(Op{int(convs_.size()) - 1, 0, 1});
      channels = int(w.shape[0]);
    } else if (item.kind == 'P') {
      ops_.push_back(Op{-1, item.a, item.b});
    } else {
      const std::string key = prefix + ".lin." + std::to_string(taps_.size()) + ".weight";
      const LpipsTensor& l = get(key);
      if (l.shape != std::vector<int64_t>{1, channels, 1, 1})
        fail(where, key + ": expected shape (1, " + std::to_string(channels) + ", 1, 1), got " + shape_str(l.shape));
      taps_.push_back(int(ops_.size()));
      lin_.emplace_back(l.data.begin(), l.data.end());
    }
  }
}

template <class T>
bool LpipsNet<T>::shapes_ok(int H, int W) const {
  int h = H, w = W;
  for (const Op& op : ops_) {
    if (op.conv >= 0) {
      const Conv& cv = convs_[size_t(op.conv)];
      if (h + 2 * cv.pad < cv.kh || w + 2 * cv.pad < cv.kw) return false;
      h = (h + 2 * cv.pad - cv.kh) / cv.stride + 1;
      w = (w + 2 * cv.pad - cv.kw) / cv.stride + 1;
    } else {
      if (h < op.k || w < op.k) return false;
      h = (h - op.k) / op.s + 1;
      w = (w - op.k) / op.s + 1;
    }
  }
  return h >= 1 && w >= 1;
}

template <class T>
int LpipsNet<T>::min_size() const {
  for (int s = 1; s <= 8192; ++s)
    if (shapes_ok(s, s)) return s;
  return -1;
}

template <class T>
void LpipsNet<T>::forward(const T* img, int H, int W, std::vector<Act>& acts) {
  acts.resize(ops_.size() + 1);
  Act& a0 = acts[0];
  a0.c = 3;
  a0.h = H;
  a0.w = W;
  const int64_t P = int64_t(H) * W;
  a0.v.resize(size_t(3 * P));
  par_for(P, 6, [&](int64_t p) {
    for (int c = 0; c < 3; ++c)
      a0.v[size_t(c * P + p)] = (T(2) * img[3 * p + c] - T(1) - T(kShift[c])) / T(kScale[c]);
  });
  for (size_t i = 0; i < ops_.size(); ++i) {
    const Op& op = ops_[i];
    const Act& in = acts[i];
    Act& out = acts[i + 1];
    const int64_t Pi = int64_t(in.h) * in.w;
    if (op.conv >= 0) {
      const Conv& cv = convs_[size_t(op.conv)];
      out.c = cv.out;
      out.h = (in.h + 2 * cv.pad - cv.kh) / cv.stride + 1;
      out.w = (in.w + 2 * cv.pad - cv.kw) / cv.stride + 1;
      const int64_t Po = int64_t(out.h) * out.w;
      out.v.resize(size_t(cv.out * Po));
      if (cv.stride == 1) {
        int Hp, Wp;
        pad_planes(in.v.data(), in.c, in.h, in.w, cv.pad, pad_, Hp, Wp);
        conv_s1(pad_.data(), cv.in, Hp, Wp, cv.w.data(), cv.out, cv.kh, cv.kw, cv.b.data(), true, false,
                out.v.data(), out.h, out.w);
        continue;
      }
      par_for(cv.out, int64_t(cv.in) * cv.kh * cv.kw * Po, [&](int64_t o) {
        T* dst = out.v.data() + o * Po;
        std::fill(dst, dst + Po, cv.b[size_t(o)]);
        for (int c = 0; c < cv.in; ++c) {
          const T* src = in.v.data() + c * Pi;
          const T* wk = cv.w.data() + (o * cv.in + c) * cv.kh * cv.kw;
          for (int ky = 0; ky < cv.kh; ++ky) {
            int y0, y1;
            valid_range(in.h, out.h, ky, cv.stride, cv.pad, y0, y1);
            for (int kx = 0; kx < cv.kw; ++kx) {
              const T wv = wk[ky * cv.kw + kx];
              int x0, x1;
              valid_range(in.w, out.w, kx, cv.stride, cv.pad, x0, x1);
              for (int oy = y0; oy < y1; ++oy) {
                const T* s = src + int64_t(oy * cv.stride + ky - cv.pad) * in.w + (kx - cv.pad);
                T* d = dst + int64_t(oy) * out.w;
                if (cv.stride == 1) {
                  for (int ox = x0; ox < x1; ++ox) d[ox] += wv * s[ox];
                } else {
                  for (int ox = x0; ox < x1; ++ox) d[ox] += wv * s[ox * cv.stride];
                }
              }
            }
          }
        }
        for (int64_t p = 0; p < Po; ++p) dst[p] = std::max(dst[p], T(0));  // ReLU
      });
    } else {
      out.c = in.c;
      out.h = (in.h - op.k) / op.s + 1;
      out.w = (in.w - op.k) / op.s + 1;
      const int64_t Po = int64_t(out.h) * out.w;
      out.v.resize(size_t(out.c * Po));
      out.arg.resize(size_t(out.c * Po));
      par_for(in.c, int64_t(op.k) * op.k * Po, [&](int64_t c) {
        const T* src = in.v.data() + c * Pi;
        for (int oy = 0; oy < out.h; ++oy)
          for (int ox = 0; ox < out.w; ++ox) {
            int32_t best = int32_t((oy * op.s) * in.w + ox * op.s);
            for (int ky = 0; ky < op.k; ++ky)
              for (int kx = 0; kx < op.k; ++kx) {
                const int32_t q = int32_t((oy * op.s + ky) * in.w + ox * op.s + kx);
                if (src[q] > src[best]) best = q;
              }
            const int64_t o = c * Po + int64_t(oy) * out.w + ox;
            out.v[size_t(o)] = src[best];
            out.arg[size_t(o)] = best;
          }
      });
    }
  }
}

template <class T>
T LpipsNet<T>::distance(const T* x, const T* y, int H, int W, T* grad, T grad_scale) {
  if (!shapes_ok(H, W))
    fail(source_.empty() ? std::string("lpips") : source_,
         std::string("image ") + std::to_string(W) + "x" + std::to_string(H) + " is smaller than the " +
             lpips_prefix(backbone_) + " network accepts (min " + std::to_string(min_size()) + "x" +
             std::to_string(min_size()) + ")");
  forward(x, H, W, ax_);
  forward(y, H, W, ay_);
  std::vector<Act> g;  // gradients by activation, only when asked
  if (grad) {
    g.resize(ax_.size());
    for (size_t i = 0; i < ax_.size(); ++i) g[i].v.assign(ax_[i].v.size(), T(0));
  }
  double total = 0.0;
  for (size_t l = 0; l < taps_.size(); ++l) {
    const Act& fx = ax_[size_t(taps_[l])];
    const Act& fy = ay_[size_t(taps_[l])];
    const int64_t P = int64_t(fx.h) * fx.w;
    const T inv_p = T(1.0 / double(P));
    const std::vector<T>& lw = lin_[l];
    T* gf = grad ? g[size_t(taps_[l])].v.data() : nullptr;
    std::vector<double> part(size_t(fx.h), 0.0);
    par_for(fx.h, 6 * int64_t(fx.w) * fx.c, [&](int64_t row) {
      double s = 0.0;
      for (int64_t p = row * fx.w; p < (row + 1) * fx.w; ++p) {
        T rx = T(0), ry = T(0);
        for (int c = 0; c < fx.c; ++c) {
          rx += fx.v[size_t(c * P + p)] * fx.v[size_t(c * P + p)];
          ry += fy.v[size_t(c * P + p)] * fy.v[size_t(c * P + p)];
        }
        rx = std::sqrt(rx);
        ry = std::sqrt(ry);
        const T ix = T(1) / (rx + T(kNormEps)), iy = T(1) / (ry + T(kNormEps));
        T dot = T(0);  // f_x . g_n, for the normalisation's Jacobian
        for (int c = 0; c < fx.c; ++c) {
          const T d = fx.v[size_t(c * P + p)] * ix - fy.v[size_t(c * P + p)] * iy;
          s += double(lw[size_t(c)] * d * d);
          if (gf) {
            const T gn = T(2) * lw[size_t(c)] * d * inv_p;
            gf[c * P + p] = gn;
            dot += fx.v[size_t(c * P + p)] * gn;
          }
        }
        if (gf) {  // d(f / (|f| + eps)) = g / (|f| + eps) - f (f . g) / (|f| (|f| + eps)^2)
          const T k2 = rx > T(0) ? dot * ix * ix / rx : T(0);
          for (int c = 0; c < fx.c; ++c) gf[c * P + p] = gf[c * P + p] * ix - fx.v[size_t(c * P + p)] * k2;
        }
      }
      part[size_t(row)] = s;
    });
    double s = 0.0;
    for (double v : part) s += v;
    total += s / double(P);
  }
  if (!grad) return T(total);

  for (size_t i = ops_.size(); i-- > 0;) {
    const Op& op = ops_[i];
    const Act& in = ax_[i];
    const Act& out = ax_[i + 1];
    std::vector<T>& gout = g[i + 1].v;
    std::vector<T>& gin = g[i].v;
    const int64_t Pi = int64_t(in.h) * in.w, Po = int64_t(out.h) * out.w;
    if (op.conv >= 0) {
      const Conv& cv = convs_[size_t(op.conv)];
      par_for(int64_t(gout.size()), 1, [&](int64_t q) {  // ReLU
        if (!(out.v[size_t(q)] > T(0))) gout[size_t(q)] = T(0);
      });
      if (!cv.wt.empty()) {  // added: gin may already hold a tap's gradient
        int Hp, Wp;
        pad_planes(gout.data(), out.c, out.h, out.w, cv.kh - 1 - cv.pad, pad_, Hp, Wp);
        conv_s1(pad_.data(), cv.out, Hp, Wp, cv.wt.data(), cv.in, cv.kh, cv.kw, static_cast<const T*>(nullptr),
                false, true, gin.data(), in.h, in.w);
        continue;
      }
      par_for(cv.in, int64_t(cv.out) * cv.kh * cv.kw * Po, [&](int64_t c) {
        T* dst = gin.data() + c * Pi;
        for (int o = 0; o < cv.out; ++o) {
          const T* go = gout.data() + o * Po;
          const T* wk = cv.w.data() + (int64_t(o) * cv.in + c) * cv.kh * cv.kw;
          for (int ky = 0; ky < cv.kh; ++ky) {
            int y0, y1;
            valid_range(in.h, out.h, ky, cv.stride, cv.pad, y0, y1);
            for (int kx = 0; kx < cv.kw; ++kx) {
              const T wv = wk[ky * cv.kw + kx];
              int x0, x1;
              valid_range(in.w, out.w, kx, cv.stride, cv.pad, x0, x1);
              for (int oy = y0; oy < y1; ++oy) {
                T* d = dst + int64_t(oy * cv.stride + ky - cv.pad) * in.w + (kx - cv.pad);
                const T* s = go + int64_t(oy) * out.w;
                if (cv.stride == 1) {
                  for (int ox = x0; ox < x1; ++ox) d[ox] += wv * s[ox];
                } else {
                  for (int ox = x0; ox < x1; ++ox) d[ox * cv.stride] += wv * s[ox];
                }
              }
            }
          }
        }
      });
    } else {
      par_for(out.c, Po, [&](int64_t c) {
        for (int64_t p = 0; p < Po; ++p) gin[size_t(c * Pi + out.arg[size_t(c * Po + p)])] += gout[size_t(c * Po + p)];
      });
    }
  }
  const int64_t P = int64_t(H) * W;
  const std::vector<T>& g0 = g[0].v;
  par_for(P, 6, [&](int64_t p) {
    for (int c = 0; c < 3; ++c) grad[3 * p + c] += grad_scale * g0[size_t(c * P + p)] * T(2.0 / kScale[c]);
  });
  return T(total);
}

template class LpipsNet<float>;
template class LpipsNet<double>;

}  // namespace haha
