// Per-frame keypoint files of tools/keypoints (docs/keypoints.md), version 1:
//
//   {"format": "haha-keypoints", "version": 1, "frame": "<image file name>",
//    "width": W, "height": H,
//    "people": N,                       people detected; 0 = nobody (body, hands null)
//    "score": s,                        detection score of the person used, [0, 1]
//    "body": [[x, y, v] x 33] | null,   BlazePose points, MediaPipe order; pixels (pixel
//                                       (i, j) covers [i, i+1) x [j, j+1)), v = visibility
//    "body_world": [[x, y, z] x 33] | null,       metres, BlazePose world frame (hip-centred, y down)
//    "left_hand": [[x, y, s] x 21] | null, "right_hand": ...   the person's own left / right
//    "mask": "masks/<stem>.png" | null, "model": "<library + model names and versions>"}
//
// Other keys are allowed (later versions may add fields) and ignored. Validation (each
// failure one haha::Error "<file>: <key>: <problem>"): format and version as above; width
// and height integers in [1, 32768]; people an integer >= 0, body null exactly when people
// is 0, hands and body_world null when body is; every point a row of 3 finite numbers,
// the exact count per list; pixel coordinates within one image size of the frame
// (kKeypointMargin: BlazePose extrapolates hidden points past the border, never far);
// scores, visibilities in [0, 1]; world points within 10 m of the hips; mask a relative
// path with no "..".
#pragma once

#include <array>
#include <string>
#include <vector>

namespace haha {

constexpr int kBodyKeypoints = 33;
constexpr int kHandKeypoints = 21;
// Pixel coordinates may lie up to this many image sizes outside the frame.
constexpr double kKeypointMargin = 1.0;
constexpr double kKeypointWorldMax = 10.0;  // metres from the hip centre

// BlazePose (MediaPipe Pose) body point indices.
namespace blazepose {
enum : int {
  nose = 0, left_eye_inner, left_eye, left_eye_outer, right_eye_inner, right_eye, right_eye_outer,
  left_ear, right_ear, mouth_left, mouth_right, left_shoulder, right_shoulder, left_elbow,
  right_elbow, left_wrist, right_wrist, left_pinky, right_pinky, left_index, right_index,
  left_thumb, right_thumb, left_hip, right_hip, left_knee, right_knee, left_ankle, right_ankle,
  left_heel, right_heel, left_foot_index, right_foot_index
};
}  // namespace blazepose

struct Keypoint2 {
  double x = 0, y = 0;  // pixels
  double score = 0;     // visibility (body) or hand score, [0, 1]
};

struct KeypointsFrame {
  std::string frame;  // the image's file name
  int width = 0, height = 0;
  int people = 0;
  double score = 0;
  std::vector<Keypoint2> body;                     // 33 or empty (null)
  std::vector<std::array<double, 3>> body_world;   // 33 or empty (null)
  std::vector<Keypoint2> left_hand, right_hand;    // 21 or empty (null)
  std::string mask;                                // relative to the keypoint folder's parent; empty = null
  std::string model;
  bool has_person() const { return !body.empty(); }
};

// Parses JSON text; `where` (a file name) starts every error message.
KeypointsFrame parse_keypoints_json(const std::string& text, const std::string& where);
KeypointsFrame read_keypoints_json(const std::string& path);

}  // namespace haha
