// Levels of detail for the avatar file: the Gaussians stored in importance tiers, so a
// loader can take a prefix ("model only what a scene needs": a distant avatar loads the
// first tier only). Importance = opacity x footprint (the two largest world scales in the
// rest pose); tier t holds the next most important Gaussians, tier sizes doubling so the
// prefixes are N/2^(T-1), ..., N/2, N. Each prefix's cost is measured at pack time.
#pragma once

#include <cstdint>
#include <vector>

#include "body/avatar.h"

namespace haha {

struct LodPlan {
  std::vector<int32_t> order;  // Gaussians, most important first
  std::vector<int> counts;     // per tier (sum = N)
  // PSNR of the avatar with tiers 0..t against the full avatar (rest pose, front and back
  // views at kLodViewSize px); the last is infinite.
  std::vector<double> psnr;
};

inline constexpr int kMaxLodTiers = 8;
inline constexpr int kLodViewSize = 256;

// tiers in [1, kMaxLodTiers]; a tier never holds fewer than one Gaussian (fewer tiers then).
LodPlan plan_lod(const Avatar& avatar, int tiers);

}  // namespace haha
