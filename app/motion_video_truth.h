// How far a motion made from a video (app/motion_from_fit.h) is from the video's true poses
// (a dataset with true fits, e.g. scripts/make-test-video.sh's synth/), as `haha motion
// --from-video --truth DIR` reports it.
#pragma once

#include <vector>

#include "body/body_model.h"
#include "fit/fit_video_truth.h"
#include "io/motion.h"

namespace haha {

struct MotionTruthErrors {
  double joint_mm = 0;        // mean body-joint (pelvis + 21) position error, root-aligned, both posed
                              // with the true body, the truth seen in the motion's world (its camera, level)
  double accel_error = 0;     // mean |acceleration - true acceleration| of those root-aligned joints, m/s^2
  double slide_cm = 0;        // mean horizontal travel of a foot over each true contact, cm (the motion's body)
  int contacts = 0;           // true contacts measured
};

// frames[t] of `m` is decoded frame truth_index[t] of the video; `player` is the body the
// motion was made for. Contacts of the truth: a foot joint slower than contact_speed m/s
// within contact_height m of its lowest height for at least min_frames frames.
MotionTruthErrors motion_truth_errors(const Motion& m, const std::vector<int>& truth_index, const FitVideoTruth& truth,
                                      const BodyModel& player, double contact_speed, double contact_height, int min_frames);

}  // namespace haha
