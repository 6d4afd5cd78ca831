// A video's per-frame SMPL-X fits (fit/fit_video.h: a static camera at the origin, OpenCV
// axes, the subject's betas) as a motion any body can play (`haha motion --from-video`):
//   - frames the fit dropped inside the clip are bridged (slerp / lerp), those at its ends cut;
//   - turned into haha's Y-up world (the camera taken as level), the ground under the feet
//     (the median over frames of the body's lowest point) at the rest soles of the body that
//     plays it;
//   - the subject's height factored out: the pelvis path is scaled by the ratio of the
//     players's leg length (rest pelvis above its soles) to the subject's;
//   - the joint rotations and the pelvis path smoothed by a zero-lag one-euro filter;
//   - feet that stay put while in contact (slow and near the ground): the root is shifted so
//     each contact foot keeps the place it landed on, the shift blended linearly between
//     contacts.
#pragma once

#include <string>
#include <vector>

#include "app/one_euro.h"
#include "body/body_model.h"
#include "fit/fit_video.h"
#include "io/motion.h"

namespace haha {

struct MotionFromFitOptions {
  OneEuroParams filter;
  double contact_speed = 0.3;    // m/s: a foot slower than this (in the player's scale) may stand
  double contact_height = 0.06;  // m: ... when its joint is at most this above its lowest height
  int min_contact_frames = 3;    // shorter stillness is a passing foot, not a step
  bool lock_feet = true;
};

struct MotionFromFitReport {
  int frames = 0, bridged = 0, cut = 0;  // output frames, frames bridged inside, dropped at the ends
  int contacts = 0;                      // foot contacts locked
  double scale = 1;                      // player's leg length / subject's
};

// `fit`: fit_video's result over `num_input_frames` frames at `fps`; `subject`: the body it
// was fitted with (betas in the params); `player`: the body whose rest shape the motion is
// scaled to (betas zero). Throws haha::Error when fewer than two frames were kept.
Motion motion_from_fit(const FitVideoResult& fit, int num_input_frames, double fps, const BodyModel& subject,
                       const BodyModel& player, const MotionFromFitOptions& options, MotionFromFitReport* report = nullptr);

// The motion as a file `haha render --motion` reads (poses (T, 165), trans (T, 3),
// mocap_frame_rate, up = +Y), written atomically.
void write_motion_npz(const Motion& m, const std::string& path);

}  // namespace haha
