// `haha fit-video`: a plain monocular video (or a folder of images) to a native dataset
// that `haha train` takes as it is. Stages: (1) frames: decoded with ffmpeg or read from
// the folder, --frames applied (app/fit_video_input.h); (2) keypoints and person masks from
// tools/keypoints (app/keypoint_tool.h); (3) the SMPL-X fit (a SmplxFitter, fit/fit_video.h);
// (4) the dataset of the kept frames, matted against the background plate when the camera
// is static (data/background_matting.h) and cropped to the person (fit/fit_video_crop.h),
// plus the fit report and contact sheet (fit/fit_video_report.h).
//
// OUT after a successful run:
//   dataset.json, images/, masks/, smplx/params.npz   the dataset (data/dataset.h)
//   body_model.npz                                     the body fitted (when save_body)
//   fit_report.json, fit_report.txt                    per input frame: kept / dropped and why,
//                                                      reprojection px, silhouette IoU (and the
//                                                      body-joint error with --truth)
//   fit_contact_sheet.png                              frames, fitted outline, keypoints
//   work/frames/%06d.png                               the selected input frames
//   work/keypoints/keypoints/*.json, work/keypoints/masks/*.png   the keypoint tool's output
//   work/keypoints.log, work/ffmpeg.log                the tool's and ffmpeg's stderr
// Everything is assembled beside OUT (OUT.fit-<pid>, OUT.fit-work-<pid>) and moved into
// place at the end: a failed or interrupted run (core/interrupt.h: the loops check the flag
// that SIGINT / SIGTERM set) leaves OUT as it was (or absent). An existing OUT is
// replaced only when it is empty or holds a dataset.json.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "app/fit_video_input.h"
#include "fit/fit_video_focal.h"
#include "fit/fit_video_report.h"
#include "fit/fit_video.h"
#include "body/body_model.h"

namespace haha {

struct FitVideoRunOptions {
  std::string input;          // a video file or a folder of .png / .jpg images
  std::string out;            // the dataset directory written
  double fps = 0;             // > 0: video resampled to this rate (ffmpeg fps filter); a folder's rate
                              // (default 30); 0: every decoded frame at the video's own rate
  double focal_px = 0;        // > 0: focal length in pixels (beats every other source; fit/fit_video_focal.h)
  double focal_35mm = 0;      // > 0: the lens's 35 mm-equivalent focal length, mm (fit/fit_video_focal.h)
  double fov_deg = 55;        // horizontal field of view, degrees: given (fov_given) or the last resort's guess
  bool fov_given = false;     // --fov given: it wins over the input's recorded focal length
  double robust_smoothness = 0;  // FitVideoWeights::smooth_sigma (rad; 0: quadratic)
  std::string frames;         // --frames A:B:S (first, last exclusive, step) after decoding; "" = all
  int test_every = 0;         // every Nth kept frame goes to the "test" split; 0: none
  int test_from = 0;          // > 0: kept frames decoded at or after this frame number go to
                              // "test" (hold out the end of a clip); 0: none
  std::string keypoint_tool;  // tools/keypoints folder ("" = find_keypoint_tool's search)
  std::string mask = "pose";  // the tool's mask: pose | selfie
  std::string keypoints = "accurate";  // the tool's models: accurate (BlazePose flip-averaged, limbs
                                       // averaged with MoveNet) | fast (BlazePose once, ~1.5x faster)
  std::string truth;          // --truth DIR: a dataset with the video's true fits (fit/fit_video_truth.h); "" = none
  bool save_body = false;     // also write OUT/body_model.npz (the body `haha train` needs by default)
  bool crop = true;           // crop the dataset to the person over the kept frames (fit/fit_video_crop.h);
                              // false (--no-crop): the whole frames
  std::string matting = "auto";  // auto: alpha and premultiplied colour against the background plate when
                                 // the camera is static (data/background_matting.h) | off: the tool's masks
  int sheet_tiles = 40;       // frames on the contact sheet (plus the dropped ones)
  bool progress = true;       // stage lines on stdout, the tool's progress passed through
};

using SmplxFitter = std::function<FitVideoResult(const std::vector<FitVideoInputFrame>&, const FitVideoOptions&)>;

// Checks the options (one haha::Error line each: "--fps: ...", "<input>: ...").
void validate_fit_video_options(const FitVideoRunOptions& opt);

// The split of the kept frame number kept_ordinal (0-based, in kept order) decoded as frame
// source_index: test under --test-every or --test-from, else train.
Split fit_video_split(const FitVideoRunOptions& opt, int kept_ordinal, int source_index);

// Stages 1-3 of a run, what `haha motion --from-video` shares with it: the frames (into
// WORK/frames), the keypoint tool's output (WORK/keypoints) and the SMPL-X fit, with the
// stage lines through `say`. Throws haha::Error when no frame could be fitted.
struct FitVideoFits {
  InputFrames in;
  FrameRange range;
  std::vector<FitVideoInputFrame> frames;
  FitVideoResult result;
  FocalChoice focal;
};
FitVideoFits fit_video_poses(const FitVideoRunOptions& opt, const SmplxFitter& fit, const std::string& work,
                             const std::function<void(const std::string&)>& say);

// The whole run. `body` draws the fitted outline on the contact sheet (and is saved with
// save_body; with --truth it poses the true fits too when DIR has no body_model.npz); `fit`
// must have been made for the same body. Throws haha::Error.
FitVideoSummary run_fit_video(const FitVideoRunOptions& opt, const BodyModel& body, const SmplxFitter& fit);

}  // namespace haha
