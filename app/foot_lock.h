// Feet that stay put while in contact: a foot joint (SMPL-X left_foot / right_foot, or
// the ankles for a motion whose feet never bend at the toes) slower
// than contact_speed and within contact_height of its lowest height for at least
// min_contact_frames frames stands; the root is shifted in x and z so that each standing
// foot keeps the place it landed on, the shift carried between contacts (in double support
// the foot that landed first holds). Used by every motion that changes a skeleton's scale:
// `haha motion --from-video` and `--retarget`.
#pragma once

#include <vector>

#include "body/lbs.h"
#include "body/smplx_params.h"

namespace haha {

struct FootLockParams {
  double contact_speed = 0.3;    // m/s: a foot slower than this (in the player's scale) may stand
  double contact_height = 0.06;  // m: ... when its joint is at most this above its lowest height
  int min_contact_frames = 3;    // shorter stillness is a passing foot, not a step
  int joints[2] = {10, 11};      // the joints that stand: left_foot, right_foot
};

// Shifts frames[t].transl (x, z) of a motion played by `lbs`'s body (Y up) at `fps`.
// Returns the number of contacts held.
int lock_feet(const Lbs<double>& lbs, std::vector<SmplxParams>& frames, double fps, const FootLockParams& params);

}  // namespace haha
