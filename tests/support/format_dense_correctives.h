// A stand-in for real SMPL-X pose correctives (which cannot be downloaded): every
// (vertex, joint) 3 x 9 block non-zero, smooth over the body, and decaying with the
// distance from the joint (SMPL-X's are dense but tiny away from each joint). Each joint
// mixes a few random 3 x 9 patterns with smooth spatial fields, so its stacked blocks have
// full rank 9 with a decaying spectrum. Scale: up to ~1 cm per radian near a joint.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "body/body_model.h"

namespace haha::test {

inline void add_dense_pose_correctives(BodyModel& b, uint32_t seed = 5, double decay_m = 0.06, double scale = 0.01) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const int V = b.num_verts;
  b.posedirs.assign(size_t(V) * 3 * kNumPoseFeatures, 0.0f);
  constexpr int kPatterns = 4;
  for (int j = 1; j < kNumJoints; ++j) {
    double J[3] = {0, 0, 0};  // rest joint: regressed from the template
    for (int v = 0; v < V; ++v)
      for (int c = 0; c < 3; ++c) J[c] += double(b.j_regressor[size_t(j) * V + v]) * b.v_template[size_t(v) * 3 + c];
    double pattern[kPatterns][27], freq[kPatterns][3], phase[kPatterns];
    for (int a = 0; a < kPatterns; ++a) {
      for (double& x : pattern[a]) x = n(rng) / (1 + a);  // later patterns weaker: a decaying spectrum
      for (double& x : freq[a]) x = 20.0 * n(rng);        // ~ one wave per 30 cm
      phase[a] = 6.28 * n(rng);
    }
    for (int v = 0; v < V; ++v) {
      double d[3], r2 = 0;
      for (int c = 0; c < 3; ++c) {
        d[c] = b.v_template[size_t(v) * 3 + c] - J[c];
        r2 += d[c] * d[c];
      }
      const double amp = scale * std::exp(-std::sqrt(r2) / decay_m);
      for (int a = 0; a < kPatterns; ++a) {
        const double f = amp * std::cos(freq[a][0] * d[0] + freq[a][1] * d[1] + freq[a][2] * d[2] + phase[a]);
        for (int c = 0; c < 3; ++c)
          for (int s = 0; s < 9; ++s)
            b.posedirs[(size_t(v) * 3 + c) * kNumPoseFeatures + 9 * (j - 1) + s] += float(f * pattern[a][c * 9 + s]);
      }
    }
  }
}

}  // namespace haha::test
