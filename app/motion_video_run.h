// `haha motion --from-video CLIP`: the poses `haha fit-video` recovers (its stages 1-3,
// app/fit_video_run.h) as a motion file any body can play (app/motion_from_fit.h), with
// progress lines; with a truth dataset, how far the motion and the raw per-frame fit are
// from the true poses (app/motion_video_truth.h).
#pragma once

#include <string>

#include "app/fit_video_run.h"
#include "app/motion_from_fit.h"

namespace haha {

struct MotionVideoOptions {
  FitVideoRunOptions fit;  // input, fps, focal, keypoint tool (its out is unused)
  std::string out;         // motion .npz
  std::string truth;       // a dataset with the clip's true fits: print the errors
  MotionFromFitOptions motion;
};

// `body`: the body the fitter fits (the subject); the motion is scaled to it at zero betas.
// Throws haha::Error naming the file or option.
void run_motion_from_video(const MotionVideoOptions& o, const BodyModel& body, const SmplxFitter& fit);

}  // namespace haha
