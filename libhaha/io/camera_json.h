// cam.json: one pinhole camera (OpenCV conventions, core/camera.h).
//
//   {"width": W, "height": H,
//    "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
//    "world_to_camera": [[r00, r01, r02, tx], [r10, r11, r12, ty], [r20, r21, r22, tz], [0, 0, 0, 1]],
//    "near": 0.01, "far": 100}                      (near and far optional: defaults 0.01, 100)
//
// K is the project camera's K as is (core/camera.h: pixel centres at +0.5, so a point
// projecting to (u, v) lies in pixel (floor(u), floor(v))). A calibration in OpenCV's own
// pixel convention (centres at integers) has cx, cy 0.5 smaller: add 0.5 when converting.
//
// Validation (each failure is a haha::Error "<file>: <key>: <problem>"): the root is an
// object with no unknown or duplicate keys; width and height are integers in [1, 32768]
// (integral floats such as 512.0 are accepted); K is 3 x 3 of finite numbers with fx, fy > 0,
// zero skew and third row (0, 0, 1) (|deviation| <= 1e-6 relative to fx resp. absolute);
// world_to_camera is 4 x 4 of finite numbers with last row (0, 0, 0, 1) (1e-6) and a rotation
// block R with max |R R^T - I| <= 1e-4 and det R > 0 (no reflection); 0 < near < far, finite.
// Values are kept as given (R is not re-orthonormalised).
#pragma once

#include <string>

#include "core/camera.h"

namespace haha {

constexpr double kCameraRotationTol = 1e-4;  // max |R R^T - I| accepted

Camera read_camera_json(const std::string& path);
// Parses JSON text; `where` (a file name) starts every error message.
Camera parse_camera_json(const std::string& text, const std::string& where);

// Shortest round-trip decimal of each float, so read(write(cam)) == cam exactly.
std::string camera_to_json(const Camera& cam);
// Validates (same rules as reading; errors name path) and writes atomically.
void write_camera_json(const std::string& path, const Camera& cam);

}  // namespace haha
