// BlazePose (tools/keypoints, io/keypoints_json.h) -> SMPL-X correspondence of the video fit
// (fit/fit_video.h): each used BlazePose point is either a body joint (shoulders, elbows,
// wrists, hips, knees, ankles) or a body surface vertex (nose, eyes, ears, heels, toe tips).
//
// Vertices: for the real SMPL-X model (10,475 vertices) a table of vertex ids as used in the
// SMPL-X fitting literature (nose tip, eyes, ears, heels, big toes); each is checked against
// the model's skinning (a head vertex must be skinned to the head / eyes, a heel to its own
// leg's ankle or foot) and the geometric choice replaces it if it fails. For any other body
// (the procedural stand-in) the vertices are found geometrically on the rest mesh (Y up,
// facing +Z, subject's left +X): nose = foremost head vertex, eye = foremost vertex of the
// eyeball (skinned to the eye joint), ear = outermost head vertex within 4 cm of eye height,
// heel = rearmost and toe = foremost vertex below the ankle skinned to that ankle / foot.
#pragma once

#include <string>
#include <vector>

#include "body/body_model.h"

namespace haha {

struct FitVideoPoint {
  int blazepose = -1;  // blazepose:: index
  int joint = -1;      // SMPL-X joint, or -1
  int vertex = -1;     // body vertex, or -1 (exactly one of joint / vertex is set)
  double weight = 1;   // relative weight in the reprojection term
  bool torso = false;  // used by the first (global orientation) stage
  std::string name;
};

// Relative weights: BlazePose's hip points sit higher and wider than SMPL-X hip joints.
constexpr double kFitVideoHipWeight = 0.4;
constexpr double kFitVideoFaceWeight = 0.3;  // nose, eyes, ears: five points close together
constexpr double kFitVideoFootWeight = 0.7;  // heels, toes

// A bone of the 3D direction term (fit/fit_video_objective.h): from point a to point b,
// indices into the correspondence.
struct FitVideoBone {
  int a = -1, b = -1;
};

// The bones whose directions BlazePose's world points give: upper and lower arms and legs,
// the shoulder and hip lines (those of `points` present; both ends joints).
std::vector<FitVideoBone> fit_video_bones(const std::vector<FitVideoPoint>& points);

// The correspondence for `body` (throws haha::Error when the body has no vertex that can
// serve as one of the surface points, e.g. a body without a head).
std::vector<FitVideoPoint> fit_video_points(const BodyModel& body);

}  // namespace haha
