// The two learning-rate groups of per-frame pose refinement and test-time pose
// optimisation (docs/method.md section 3), derived from the joint layout:
//   body: global orient + the 21 body joints + translation   (lr_pose)
//   fine: jaw and both hands                                 (lr_pose_fine)
// The eyes are not optimised. Both the trainer and the evaluation use these.
#pragma once

#include <array>

#include "body/body_model.h"
#include "body/smplx_params.h"

namespace haha {

inline constexpr int kPoseBodyValues = 3 * kJaw;                 // pose values before the jaw
inline constexpr int kPoseBodyGroup = kPoseBodyValues + 3;       // + translation
inline constexpr int kPoseFineGroup = kNumPoseValues - kPoseBodyValues - 3 * (kLeftHandFirst - kLeftEye);

// Pose value q (0..164) belongs to the fine group (jaw, hands; not the eyes).
inline constexpr bool in_fine_group(int q) {
  return q >= kPoseBodyValues && (q < 3 * kLeftEye || q >= 3 * kLeftHandFirst);
}

// p's values as the two groups (body: kPoseBodyGroup, fine: kPoseFineGroup values). P is
// SmplxParams or its gradient (anything with `pose` (165) and `transl` (3) arrays).
// `accumulate`: add to body / fine (gradients) instead of overwriting them.
template <class P>
void pose_to_groups(const P& p, float* body, float* fine, bool accumulate = false) {
  auto put = [&](float* dst, float v) { *dst = accumulate ? *dst + float(v) : float(v); };
  for (int q = 0; q < kPoseBodyValues; ++q) put(&body[q], p.pose[size_t(q)]);
  for (int q = 0; q < 3; ++q) put(&body[kPoseBodyValues + q], p.transl[size_t(q)]);
  int o = 0;
  for (int q = kPoseBodyValues; q < kNumPoseValues; ++q)
    if (in_fine_group(q)) put(&fine[o++], p.pose[size_t(q)]);
}

// The inverse: writes the groups' values back into p (other values untouched).
inline void groups_to_pose(const float* body, const float* fine, SmplxParams& p) {
  for (int q = 0; q < kPoseBodyValues; ++q) p.pose[size_t(q)] = body[q];
  for (int q = 0; q < 3; ++q) p.transl[size_t(q)] = body[kPoseBodyValues + q];
  int o = 0;
  for (int q = kPoseBodyValues; q < kNumPoseValues; ++q)
    if (in_fine_group(q)) p.pose[size_t(q)] = fine[o++];
}

static_assert(kPoseBodyGroup == 69 && kPoseFineGroup == 93, "jaw + 2 x 15 finger joints = 93 values");

}  // namespace haha
