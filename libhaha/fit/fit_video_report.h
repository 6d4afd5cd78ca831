// What `haha fit-video` reports: per input frame kept or dropped (and why), keypoint
// reprojection error and silhouette IoU, as OUT/fit_report.json and a plain text table
// (OUT/fit_report.txt), and a contact sheet of frames with the fitted body's outline and
// the keypoints drawn over them (OUT/fit_contact_sheet.png).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "data/dataset.h"
#include "io/image.h"
#include "io/keypoints_json.h"
#include "core/camera.h"

namespace haha {

struct FitVideoFrameRow {
  std::string name;           // input image name, or "frame N" of a video
  int source_index = 0;       // among the decoded / found frames
  bool dropped = false;
  std::string reason;         // why dropped
  double reprojection_px = 0; // NaN: not measured
  double silhouette_iou = 0;  // NaN: not measured
  double joint_error_mm = NAN;  // PA-MPJPE against --truth (fit/fit_video_truth.h); NaN: not measured
  double orient_error_deg = NAN;  // body orientation as the camera sees it, against --truth; NaN: not measured
  int dataset_frame = -1;     // row in the written dataset (-1: dropped)
  Split split = Split::train;
};

struct FitVideoSummary {
  std::string input, out;
  int decoded = 0;            // frames decoded (video) or images found (folder)
  int kept = 0, dropped = 0, train = 0, test = 0;
  int width = 0, height = 0;
  double fps = 0;             // of the dataset (after --fps and the --frames step)
  Camera camera;
  std::string focal_source;   // where the focal length came from (fit/fit_video_focal.h)
  std::vector<FitVideoFrameRow> frames;  // one per frame given to the fit
  // The dataset's frames: this box of the input frames (the whole frame with --no-crop;
  // fit/fit_video_crop.h) and the person's height in it (the box of the person over the
  // kept frames; 0: not measured), also at the standard preset's training size (the
  // dataset's longer side scaled to train_resolution px).
  bool cropped = false;        // false: --no-crop
  int crop_x0 = 0, crop_y0 = 0, crop_w = 0, crop_h = 0;
  int person_height_px = 0;
  int train_resolution = 0;
  // Matting against the background plate (data/background_matting.h): the option, the
  // plate (frames used of those given, share of holes), the background residual against
  // the camera's threshold, and whether the dataset is matted (premultiplied).
  std::string matting;            // auto | off ("" = not reported)
  bool matting_used = false;
  int plate_frames = 0, plate_candidates = 0;
  double plate_hole_share = NAN, plate_filled_share = NAN;  // holes: never seen; filled: holes filled from a plain wall
  double background_residual = NAN, static_threshold = NAN;
  double matted_band_share = NAN;  // share of the kept frames' edge band where the plate was known (matted)
  double filled_band_share = NAN;  // ... where it was a filled hole
  double mean_reprojection_px = 0, mean_silhouette_iou = 0;  // over kept frames with a value (NaN: none)
  std::string truth;               // --truth DIR ("" = none): the joint error is reported
  double mean_joint_error_mm = NAN;  // over kept frames with a value (NaN: none)
  double mean_orient_error_deg = NAN;
};

// Means over kept frames of the finite values; fills summary.mean_*.
void summarize_fit(FitVideoSummary& s);

// The report's lines on the crop and on the matting ("" when not reported).
std::string crop_report_line(const FitVideoSummary& s);
std::string matting_report_line(const FitVideoSummary& s);

std::string fit_report_json(const FitVideoSummary& s);
std::string fit_report_table(const FitVideoSummary& s);

// The frame (RGB) with the posed body's outline (the mesh rasterizer's silhouette edge,
// through `cam`; skipped when `verts` is empty) and the keypoints drawn over it; a dropped
// frame gets a red border.
Image draw_fit_overlay(const Image& rgb, const Camera& cam, const BodyModel& body, const std::vector<float>& verts,
                       const KeypointsFrame& kp, bool dropped);

// Indices of the frames shown on the sheet: `max_tiles` spread evenly over [0, n) plus every
// dropped one (up to `max_tiles` more), increasing.
std::vector<int> sheet_frames(const std::vector<FitVideoFrameRow>& rows, int max_tiles);

// A label for a sheet tile: "<name> <px>PX IOU<iou>" or "<name> DROP: <reason>".
std::string sheet_label(const FitVideoFrameRow& row);

}  // namespace haha
