// SMPL-X fits from a plain monocular video's per-frame keypoints and masks (tools/keypoints,
// docs/keypoints.md): the fit behind `haha fit-video`. One static pinhole camera at the
// origin (OpenCV axes, render/camera.h), betas shared by the whole video, per-frame pose,
// global orient and transl. Frames without a usable person are reported and dropped.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "io/image.h"
#include "io/keypoints_json.h"
#include "render/camera.h"

namespace haha {

struct VideoFitInputFrame {
  KeypointsFrame keypoints;  // one frame of tools/keypoints output
  Image mask;                // optional person mask (empty = none), the frame's size, 1 channel, 1 = person
};

struct VideoFitOptions {
  double focal_px = 0;  // > 0: focal length in pixels; 0: from fov_deg and the frame width
  double fov_deg = 55;  // horizontal field of view guessed when focal_px is 0
  bool progress = true; // stage, iteration, loss, ETA on stdout
};

struct VideoFitFrameReport {
  std::string frame;             // keypoints.frame
  bool dropped = false;
  std::string reason;            // why it was dropped ("nobody in the frame", "person cut off", ...)
  double reprojection_px = NAN;  // mean visibility-weighted keypoint error after the fit
  double silhouette_iou = NAN;   // body silhouette vs the mask after the fit (NaN: no mask)
};

struct VideoFitResult {
  Camera camera;                            // K from the focal and the frame centre, identity extrinsics
  std::vector<int> kept;                    // input indices of the fitted frames, increasing
  std::vector<SmplxParams> params;          // one per kept frame (shared betas)
  std::vector<VideoFitFrameReport> report;  // one per input frame
};

// Throws haha::Error for inconsistent input (frames of different sizes, no frame with a person).
VideoFitResult fit_video(const BodyModel& body, const std::vector<VideoFitInputFrame>& frames,
                         const VideoFitOptions& opt = {});

}  // namespace haha
