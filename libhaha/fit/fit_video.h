// SMPL-X fits from a plain monocular video's per-frame keypoints and masks (tools/keypoints,
// docs/keypoints.md): the fit behind `haha fit-video`. One static pinhole camera at the
// origin (OpenCV axes, core/camera.h), betas shared by the whole video, per-frame pose,
// global orient and transl. Frames without a usable person are reported and dropped.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "io/image.h"
#include "fit/fit_video_objective.h"
#include "io/keypoints_json.h"
#include "core/camera.h"

namespace haha {

struct FitVideoInputFrame {
  KeypointsFrame keypoints;  // one frame of tools/keypoints output
  Image mask;                // optional person mask (empty = none), the frame's size, 1 channel, 1 = person
};

struct FitVideoOptions {
  double focal_px = 0;  // > 0: focal length in pixels; 0: from fov_deg and the frame width
  double fov_deg = 55;  // horizontal field of view guessed when focal_px is 0
  bool progress = true; // stage, iteration, loss, ETA on stdout
  double frame_interval_s = 1.0 / 30;  // seconds between consecutive input frames (the smoothness'
                                       // scale, fit/fit_video_objective.h)

  // Which frames are fitted (fit/fit_video_frames.h).
  double min_score = 0.5;          // detection score below this: dropped
  double min_visibility = 0.5;     // a keypoint counts as seen at this visibility
  double min_seen_fraction = 0.5;  // of the 12 limb and torso points, seen inside the frame
  double cut_jump = 1.0;           // torso centre moving more than this many torso lengths
                                   // from the previous frame: scene cut
  double cut_scale = 1.6;          // torso length changing by more than this factor: scene cut

  // The fit (fit/fit_video_objective.h for the objective and its weights). Stages, as in
  // SMPLify: global orient and transl on the torso and face points; then everything; then,
  // where frames have masks, everything plus the silhouette term.
  FitVideoWeights weights;
  bool use_world = true;  // BlazePose's world points (when the keypoints have them) seed the pose and
                          // feed the bone-direction term; false: ignored (the 2D-only fit)
  bool fade_hidden_face = true;  // the nose, eyes and mouth weighted by how far the fitted head
                                 // faces the camera (fit/fit_video_facing.h); false: as BlazePose says
  int num_betas = 10;
  int iters_global = 60, iters_body = 300, iters_silhouette = 40;
  double lr_orient = 0.03, lr_body = 0.03, lr_transl = 0.02, lr_betas = 0.03;  // Adam, per stage
  double lr_final_factor = 0.1;  // log-linear decay to this fraction over each stage
  // Silhouette term: w_silhouette x silhouette_mismatch (train/silhouette_fit.h) of the
  // antialiased body silhouette against the mask, rendered with the frame scaled so that
  // its longer side is at most silhouette_size pixels.
  double w_silhouette = 0.05, silhouette_outside = 1.0, silhouette_inside = 0.3;
  int silhouette_size = 192;
};

struct FitVideoFrameReport {
  std::string frame;             // keypoints.frame
  bool dropped = false;
  std::string reason;            // why it was dropped ("nobody in the frame", "person cut off", ...)
  double reprojection_px = NAN;  // mean visibility-weighted keypoint error after the fit
  double silhouette_iou = NAN;   // body silhouette vs the mask after the fit (NaN: no mask)
};

struct FitVideoResult {
  Camera camera;                            // K from the focal and the frame centre, identity extrinsics
  std::vector<int> kept;                    // input indices of the fitted frames, increasing
  std::vector<SmplxParams> params;          // one per kept frame (shared betas)
  std::vector<FitVideoFrameReport> report;  // one per input frame
};

// Throws haha::Error for inconsistent input (frames of different sizes, no frame with a person).
FitVideoResult fit_video(const BodyModel& body, const std::vector<FitVideoInputFrame>& frames,
                         const FitVideoOptions& opt = {});

}  // namespace haha
