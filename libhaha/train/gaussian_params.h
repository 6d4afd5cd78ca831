// The trainable state of the face-bound Gaussians in unconstrained form, the activations
// (written once, forward and backward side by side) and the bookkeeping of densification
// and pruning (index lists that the optimiser's reindex() takes as well).
//
// Activations (docs/method.md section 1; the release's):
//   scale   = scale_max * sigmoid(scale_logit)   (units of the face scale k)
//   colour  = sigmoid(color_logit)               (linear RGB in (0, 1))
//   opacity = sigmoid(opacity_logit)
//   rotation: the raw quaternion is used as is. Face frames compose it as q(R) * r and the
//   rasterizer normalises its input, so |r| drops out of the rendered image; it is
//   normalised only when the avatar is exported.
#pragma once

#include <cstdint>
#include <vector>

#include "body/avatar.h"
#include "core/hd.h"
#include "core/math.h"

namespace haha {

struct GaussianParams {
  std::vector<int32_t> face;         // (N) parent face
  std::vector<float> offset;         // (N, 3) local mean mu (units of k, face frame)
  std::vector<float> rotation;       // (N, 4) raw quaternion (w, x, y, z)
  std::vector<float> scale_logit;    // (N, 3)
  std::vector<float> color_logit;    // (N, 3)
  std::vector<float> opacity_logit;  // (N)

  int size() const { return int(face.size()); }
  void resize(int n);
};

// Activated values (SoA), what the posing / rasterizer chain reads.
struct ActivatedGaussians {
  std::vector<float> scale, color, opacity;  // (N,3), (N,3), (N)
};

// Logit of p, with p clamped to [eps, 1 - eps] so saturated values stay finite.
inline constexpr double kLogitEps = 1e-6;
template <class T>
HAHA_HD T logit(T p) {
  const T lo = T(kLogitEps), hi = T(1) - T(kLogitEps);
  p = p < lo ? lo : (p > hi ? hi : p);
  return std::log(p / (T(1) - p));
}

// y = a * sigmoid(x) and dy/dx = y (1 - y / a), from the output (both passes use this).
template <class T>
HAHA_HD T scaled_sigmoid(T x, T a) { return a * sigmoid(x); }
template <class T>
HAHA_HD T scaled_sigmoid_grad_from_output(T y, T a) { return y * (T(1) - y / a); }

// One Gaussian per face, centred on the face (offset 0), identity rotation, the given
// activated scale, grey level and opacity.
GaussianParams init_one_per_face(int num_faces, float scale, float color, float opacity, float scale_max);

// Activations of all Gaussians (out is resized).
void activate(const GaussianParams& g, float scale_max, ActivatedGaussians& out);

// Chain rule of the activations: logit gradients from activated gradients (any pointer may
// be null = that group not wanted). Overwrites the outputs.
void activation_backward(const ActivatedGaussians& act, float scale_max, int n, const float* d_scale,
                         const float* d_color, const float* d_opacity, float* d_scale_logit, float* d_color_logit,
                         float* d_opacity_logit);

// r / |r| with |r|^2 floored at 1e-30 (the KNN regulariser's unit rotation; its gradient
// is normalize_quat_backward below).
template <class T>
HAHA_HD void normalize_quat(const T* r, T* out) {
  const T n2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
  const T len = std::sqrt(n2 < T(1e-30) ? T(1e-30) : n2);  // std::max(n2, 1e-30) with NaN kept
  for (int c = 0; c < 4; ++c) out[c] = r[c] / len;
}

// d/dr of normalize(r) applied to d_n (gradient w.r.t. the unit quaternion): d_r (4).
template <class T>
HAHA_HD void normalize_quat_backward(const T* r, const T* d_n, T* d_r) {
  const T n2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
  const T inv = T(1) / std::sqrt(n2 > T(1e-30) ? n2 : T(1e-30));
  T dot_nd = 0;
  for (int i = 0; i < 4; ++i) dot_nd += r[i] * inv * d_n[i];
  for (int i = 0; i < 4; ++i) d_r[i] = (d_n[i] - r[i] * inv * dot_nd) * inv;
}

// The avatar's Gaussians (activated, unit rotations) from the parameters, and back.
// from_bound clamps activated values into the open ranges of the activations.
BoundGaussians to_bound(const GaussianParams& g, float scale_max);
GaussianParams from_bound(const BoundGaussians& b, float scale_max);

// Keeps the Gaussians whose index is listed (ascending or not; order is the new order).
void select(GaussianParams& g, const std::vector<int64_t>& keep);
// Indices i with keep[i] != 0, ascending.
std::vector<int64_t> indices_where(const std::vector<uint8_t>& keep);

// Densification plan: which Gaussians to clone and which to split (old indices).
struct DensifyPlan {
  std::vector<int64_t> clone, split;
};
// For each Gaussian of the result, the old index whose optimiser moments it keeps, or -1
// for a new one (3DGS gives clones and split children fresh moments): what
// Adam::reindex takes.
struct DensifyResult {
  std::vector<int64_t> adam_source;
  int cloned = 0, split = 0;
};

// Chooses clone / split by the mean screen-space gradient norm: avg = grad_accum / count
// (count > 0) >= threshold; max local scale <= clone_scale -> clone, else split. When the
// result would exceed max_count, the Gaussians with the largest avg are taken first
// (ties by index). Deterministic.
DensifyPlan plan_densify(const GaussianParams& g, float scale_max, const std::vector<float>& grad_accum,
                         const std::vector<float>& count, double threshold, double clone_scale, int max_count);

// Applies a plan. Clones: an exact copy (same face, same parameters). Splits: the parent
// is removed and two children added, each at parent offset + R(r) (std * s * z) with
// z ~ N(0, 1) drawn from (seed, parent index, child), the face-frame y component of that
// displacement (y = the face normal) made non-negative so children go to the outer side,
// scales divided by split_div. Children keep the parent's face, rotation, colour and
// opacity. Order of the result: the kept old Gaussians in order, then clones, then split
// children.
DensifyResult apply_densify(GaussianParams& g, const DensifyPlan& plan, float scale_max, double split_std,
                            double split_div, uint64_t seed);

// Counter-based random numbers (splitmix64 of a hash of the inputs): the same (seed,
// stream, index) always gives the same value, so a resumed run repeats every random choice
// without storing generator state.
uint64_t hash64(uint64_t seed, uint64_t stream, uint64_t index);
double uniform01(uint64_t seed, uint64_t stream, uint64_t index);  // [0, 1)
double normal01(uint64_t seed, uint64_t stream, uint64_t index);   // N(0, 1), Box-Muller
// Draw k of epochs over n items (n > 0): each epoch of n draws is a seeded permutation
// (Fisher-Yates on uniform01 of this stream), so every item is drawn once per epoch.
int epoch_draw(uint64_t seed, uint64_t stream, int n, int64_t k);

}  // namespace haha
