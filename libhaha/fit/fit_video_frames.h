// Which frames of a video the fit uses (fit/fit_video.h), and their 2D targets. A frame is
// dropped, with the reason, when nobody is detected, the detection score is low, no
// shoulder or no hip or less than min_seen_fraction of the 12 limb and torso points are
// seen inside the frame ("person cut off"
// when those points lie outside it), or the torso jumps from the previous frame (a scene
// cut: its centre moves more than cut_jump torso lengths or its length changes by more
// than cut_scale). Kept frames link to the previous one for the temporal terms only when it
// is the previous input frame and was kept (opt.frame_interval_s before it). A frame's
// BlazePose world points, when it has them, become its targets' world points.
#pragma once

#include <string>
#include <vector>

#include "fit/fit_video.h"
#include "fit/fit_video_objective.h"

namespace haha {

struct FitVideoSelection {
  std::vector<std::string> reason;       // per input frame; empty = kept
  std::vector<int> kept;                 // input indices, increasing
  std::vector<FitVideoTargets> targets;  // per kept frame
};

// Visibility of keypoints outside the frame counts as 0 in the targets (BlazePose
// extrapolates hidden points there).
FitVideoSelection select_video_frames(const std::vector<FitVideoInputFrame>& frames,
                                      const std::vector<FitVideoPoint>& points, const FitVideoOptions& opt);

// 2D torso of a frame's body points: centre (mean of shoulders and hips) and size (the
// larger of the shoulder-hip distance and the shoulder and hip widths, >= 1 px).
struct Torso2D {
  double x = 0, y = 0, size = 1;
};
Torso2D torso_2d(const KeypointsFrame& k);

}  // namespace haha
