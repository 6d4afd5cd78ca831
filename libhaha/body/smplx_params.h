// Per-frame SMPL-X parameters as stored in fits (names as in SMPL-X fitting code).
#pragma once

#include <array>
#include <vector>

#include "body/body_model.h"

namespace haha {

struct SmplxParams {
  // Full pose: 55 joints x axis-angle = global_orient | body(21) | jaw | leye | reye |
  // left hand(15) | right hand(15).
  std::array<float, kNumPoseValues> pose{};
  std::vector<float> betas;       // any length <= model.num_shape (missing = 0)
  std::vector<float> expression;  // any length <= model.num_expr
  std::array<float, 3> transl{};
};

}  // namespace haha
