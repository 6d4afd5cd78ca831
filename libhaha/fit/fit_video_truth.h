// The end-to-end measurement of `haha fit-video --truth DIR`: DIR is a native
// dataset holding the true fits of the video's frames in order (e.g. the synth/ folder of
// scripts/make-test-video.sh, whose video.mp4 is its frames 0..N-1), and each kept frame's
// fit is compared with the true fit of the frame it was decoded as (its source_index): the
// body-joint error (pelvis + 21 body joints) after a per-frame similarity Procrustes
// alignment (PA-MPJPE, core/procrustes.h), in mm, and the error of the body's orientation as
// its camera sees it, in degrees: Procrustes hides it, and it is what makes a turning
// subject's views disagree when an avatar is trained on the fits.
#pragma once

#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/lbs.h"
#include "body/smplx_params.h"
#include "core/camera.h"

namespace haha {

struct FitVideoTruth {
  std::string dir;
  std::vector<SmplxParams> params;  // per DIR frame, in order: its true fits (smplx_true) when it has them, else its fits
  std::vector<Camera> cameras;      // per DIR frame
  BodyModel body;                   // DIR/body_model.npz; else the body given to read_fit_video_truth
  bool own_body = false;            // whether body came from DIR
};

// Reads DIR's dataset.json and fits (pixels are not decoded) and its body. One haha::Error
// line naming DIR when it is not a dataset or holds no frames.
FitVideoTruth read_fit_video_truth(const std::string& dir, const BodyModel& fallback_body);

// The truth must cover every decoded frame of the video: one line naming DIR otherwise.
void check_truth_frames(const FitVideoTruth& t, int decoded_frames);

// PA-MPJPE (mm) over the pelvis and the 21 body joints of `fit` posed with `fit_body` against
// `truth` posed with `truth_body` (built once per body: an Lbs precomputes its weights).
double body_joint_pa_error_mm(const Lbs<double>& fit_body, const SmplxParams& fit, const Lbs<double>& truth_body,
                              const SmplxParams& truth);

// Angle (degrees) between the body's orientation in its camera's frame, R_cam R(global
// orient), of the fit and of the truth: 0 when the fit sees the body turned as the truth does.
double body_orient_error_deg(const Camera& fit_camera, const SmplxParams& fit, const Camera& truth_camera,
                             const SmplxParams& truth);

}  // namespace haha
