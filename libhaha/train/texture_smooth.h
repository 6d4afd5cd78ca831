// The stage-2 prior that lets texels the video barely saw take their colour from their
// neighbours: a quadratic smoothness term whose per-texel weight falls with evidence
// (train/texture_evidence.h), so well-seen texels keep their detail and barely-seen ones
// follow the surrounding colour instead of the few noisy gradients they got.
//
//   E = sum over 4-neighbour texel pairs (i, j) of min(a_i, a_j) * sum_c (t_ic - t_jc)^2
//       / (H W C)
//
// with a_i = 1 / (1 + evidence_i / evidence_full) inside charts and 0 in the gutter (pairs
// with a gutter texel carry no weight: the gutter is not content).
#pragma once

#include <cstdint>
#include <vector>

#include "render/texture_charts.h"

namespace haha {

// a (H * W) from evidence (H * W) and the charts (of the same size); evidence_full > 0.
std::vector<float> smooth_weights(const std::vector<float>& evidence, const TextureCharts& charts,
                                  double evidence_full);

// E above for tex (H, W, C) and weights a (H * W); grad (may be null) is ACCUMULATED with
// dE/dtex * grad_scale.
template <class T>
T texture_smooth_loss(const T* tex, const float* a, int H, int W, int C, T* grad = nullptr, T grad_scale = T(1));

}  // namespace haha
