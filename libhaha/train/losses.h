// Image losses and regularisers of the HAHA trainer (docs/method.md section 3), each a value
// and its gradient computed side by side in one function, templated on the scalar
// (instantiated for float, used in training, and double, used by the finite-difference
// tests).
//
// Buffer contract, common to every function here:
//   - Images are (H, W, 3) row-major, channels interleaved: x[(y * W + x) * 3 + c].
//   - `weights` is an optional per-pixel (H, W) array (nullptr = all ones): a mask or a
//     soft weight, >= 0. It is never differentiated.
//   - `grad` is optional (nullptr = value only). When given, the function ADDS
//     `grad_scale * dLoss/dinput` into it, so a trainer can sum weighted terms into one
//     buffer (zero it first). Only the first image argument (the render / prediction)
//     receives a gradient; the second (ground truth) is a constant.
//   - Buffers are caller-allocated; `LossScratch` is reused across calls, so a call
//     allocates only its small per-row partial-sum array (nothing per pixel).
//   - Sums are accumulated in double over fixed row / chunk partitions and added in a fixed
//     order, so values do not depend on the thread count (a resumed run repeats itself).
// Kinks (|.| at 0, sqrt near 0) take the subgradient 0; finite-difference tests stay away
// from them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace haha {

// Grown-on-demand scratch memory for the image losses (SSIM and the edge loss).
template <class T>
class LossScratch {
 public:
  T* get(size_t n) {
    if (buf_.size() < n) buf_.resize(n);
    return buf_.data();
  }

 private:
  std::vector<T> buf_;
};

// ---- L2 ------------------------------------------------------------------------------
// Mean squared error over the (weighted) pixels and 3 channels:
//   L = sum_p w_p sum_c (x - y)^2 / (3 sum_p w_p).
// weights == nullptr gives the plain mean over H*W*3 values. sum w = 0 gives L = 0 and
// no gradient. A zero-weight pixel contributes nothing to L or its gradient.
template <class T>
T l2_loss(const T* x, const T* y, int H, int W, const T* weights = nullptr, T* grad = nullptr,
          T grad_scale = T(1));

// ---- SSIM ----------------------------------------------------------------------------
// The 3DGS / pytorch-ssim definition: 11 x 11 Gaussian window (sigma 1.5, separable,
// normalised), zero padding of 5 at the image border (F.conv2d(padding=5)), per channel,
//   S = (2 mu_x mu_y + C1)(2 s_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(s_x + s_y + C2)),
// C1 = 0.01^2, C2 = 0.03^2 (data range 1). SSIM = (weighted) mean of S over pixels and
// channels; the loss is 1 - SSIM.
inline constexpr int kSsimWindow = 11;
inline constexpr double kSsimSigma = 1.5;
inline constexpr double kSsimC1 = 0.01 * 0.01;
inline constexpr double kSsimC2 = 0.03 * 0.03;

// L = 1 - sum_p w_p mean_c S(p, c) / sum_p w_p (sum w = 0 gives 0, no gradient).
// Scratch: 10 * H * W values.
template <class T>
T ssim_loss(const T* x, const T* y, int H, int W, LossScratch<T>& scratch, const T* weights = nullptr,
            T* grad = nullptr, T grad_scale = T(1));

// Evaluation SSIM (a value in [-1, 1], 1 for equal images), computed in double.
// valid_only = false: the training definition above (mean over every pixel, zero-padded
// windows, what 3DGS's metrics report). valid_only = true: mean over the pixels whose
// window lies inside the image (skimage / torchmetrics crop the 5-pixel border this way);
// images smaller than 11 x 11 fall back to every pixel.
double ssim_metric(const float* x, const float* y, int H, int W, bool valid_only = false);

// PSNR with data range 1: 10 log10(1 / MSE), MSE over pixels and channels (weighted as
// l2_loss when weights are given). Equal images give +infinity (documented, not clamped);
// an empty weight mask gives NaN.
double psnr(const float* x, const float* y, int H, int W, const float* weights = nullptr);

// ---- Edge ("Sobel") loss ---------------------------------------------------------------
// The release's edge term: luminance l = 0.257 R + 0.504 G + 0.098 B, central differences
// gx = l(i, j+1) - l(i, j-1), gy = l(i+1, j) - l(i-1, j), magnitude
// m = sqrt(gx^2 + gy^2 + 1e-6); L = sum_p w_p |m_x(p) - m_y(p)| / sum_p w_p.
// Border: indices are clamped to the image (replicate padding), so a border pixel uses the
// one-sided difference l(i, 1) - l(i, 0) and the image frame itself creates no edge.
// Every pixel counts. Scratch: 4 * H * W values.
inline constexpr double kEdgeLumR = 0.257, kEdgeLumG = 0.504, kEdgeLumB = 0.098;
inline constexpr double kEdgeEps = 1e-6;
template <class T>
T edge_loss(const T* x, const T* y, int H, int W, LossScratch<T>& scratch, const T* weights = nullptr,
            T* grad = nullptr, T grad_scale = T(1));

// ---- Dice ------------------------------------------------------------------------------
// L = 1 - (2 sum p t + 1) / (sum p + sum t + 1) over n values (silhouettes in [0, 1]).
// Gradient with respect to p only.
template <class T>
T dice_loss(const T* p, const T* t, int64_t n, T* grad = nullptr, T grad_scale = T(1));

// ---- Texture total variation -----------------------------------------------------------
// Anisotropic L1 TV normalised by element count (torchmetrics TotalVariation / numel, as
// the release): L = (sum |t(i, j+1) - t(i, j)| + sum |t(i+1, j) - t(i, j)|) / (H W C),
// texture (H, W, C) row-major interleaved.
template <class T>
T texture_tv_loss(const T* tex, int H, int W, int C, T* grad = nullptr, T grad_scale = T(1));

// ---- Opacity regulariser ----------------------------------------------------------------
// SumSquares: L = sum o^2 (the paper, weight 0.001). MeanAbs: L = mean |o| (the release,
// L1 of the opacity). o = activated opacities (n). n = 0 gives 0.
enum class OpacityRegMode { SumSquares, MeanAbs };
template <class T>
T opacity_reg(const T* opacity, int64_t n, OpacityRegMode mode, T* grad = nullptr, T grad_scale = T(1));

// ---- Stretch regulariser ---------------------------------------------------------------
// What the Gaussians of faces that stretch with the arms may do (train/face_stretch.h):
//   L = mean_i stretch[face_i] * (|offset_i|^2 + |scale_i|^2)
// face (n) parent faces, stretch (F) per-face weights >= 0, offset (n, 3) local means and
// scale (n, 3) activated local scales, both in units of the face scale k. grad_offset /
// grad_scale (either may be null) get grad_k * dL/d(.) added. n = 0 gives 0.
template <class T>
T stretch_reg(const int32_t* face, const float* stretch, const T* offset, const T* scale, int64_t n,
              T* grad_offset = nullptr, T* grad_scale = nullptr, T grad_k = T(1));

// ---- KNN regulariser ----------------------------------------------------------------------
// For each Gaussian i, its set is row i of `sets` (n, K) — the release queries the posed
// centres against themselves (pytorch3d knn_points, K = 3), so the row is i itself and its
// K-1 nearest others: see knn_sets() in train/knn.h. Entries < 0 are skipped.
//   L = mean_i [ w_rot   mean_d std_{j in set(i)} rotation_j[d]   (d over 4)
//              + w_scale mean_d std scale_j[d]                     (3)
//              + w_opac  std opacity_j                             (1)
//              + w_col   mean_d std colour_j[d]                    (3) ]
//     + w_dist sum_i sum_{j in set(i)} |p_i - p_j|^2 / (n K)
// std is the unbiased one (divides by m - 1, as torch.std), set to 0 for sets of m < 2;
// it is computed as sqrt(var + eps) - sqrt(eps) (eps = 1e-20) so that equal values give 0
// with a finite gradient. Any attribute pointer may be null (term off). The sets are held
// fixed: no gradient flows through the neighbour choice. The caller passes whichever form
// it regularises (the release: activated scale/opacity/colour, normalised rotation) and
// chains the gradient.
inline constexpr double kKnnStdEps = 1e-20;
template <class T>
struct KnnRegInputs {
  int64_t n = 0;
  const T* position = nullptr;  // (n, 3) posed centres (distance term)
  const T* rotation = nullptr;  // (n, 4)
  const T* scale = nullptr;     // (n, 3)
  const T* opacity = nullptr;   // (n)
  const T* color = nullptr;     // (n, 3)
};
struct KnnRegWeights {
  double rotation = 1, scale = 1, opacity = 1, color = 1, distance = 1;
};
template <class T>
struct KnnRegGrads {  // each optional; accumulated (+= grad_scale * dL/d.)
  T* position = nullptr;
  T* rotation = nullptr;
  T* scale = nullptr;
  T* opacity = nullptr;
  T* color = nullptr;
};
template <class T>
T knn_reg(const KnnRegInputs<T>& in, const int32_t* sets, int K, const KnnRegWeights& w = {},
          const KnnRegGrads<T>* grads = nullptr, T grad_scale = T(1));

}  // namespace haha
