// Fixtures of the video-fit tests: synthetic BlazePose keypoints of a posed body (the fit's
// own correspondence projected through the camera, hips shifted towards the shoulders as
// BlazePose places them, Gaussian pixel noise, visibility dropouts), a writer of the
// keypoint JSON contract (docs/keypoints.md). The body-joint error after a per-frame
// similarity Procrustes alignment (PA-MPJPE): core/procrustes.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "fit/fit_video_points.h"
#include "body/lbs.h"
#include "core/math.h"
#include "io/keypoints_json.h"
#include "core/camera.h"

namespace haha::test {

struct SyntheticKeypointOptions {
  double noise_px = 2.5;      // Gaussian sigma per coordinate
  double dropout = 0.1;       // chance that a point is reported hidden (visibility 0.1, displaced)
  double hip_shift = 0.08;    // hips moved this fraction of the torso towards the shoulders
  // BlazePose's world points (body_world): the same points in camera axes, metres, centred
  // between the (shifted) hips, each moved by Gaussian noise of this sigma per coordinate.
  // 4.5 cm: the tool's world points on the synthetic test video (scripts/make-test-video.sh)
  // are 60 mm from the true joints after Procrustes and their arm bones 16-20 degrees off;
  // independent 4.5 cm noise gives about both (mean 3D offset 1.6 sigma = 72 mm before
  // alignment, a 0.28 m bone about 17 degrees). Negative: body_world null (2D only).
  double world_noise_m = 0.045;
};

// Keypoints of `params` posed by lbs, seen by cam; frame name `name`.
inline KeypointsFrame synthetic_keypoints(const Lbs<double>& lbs, const std::vector<FitVideoPoint>& points,
                                          const SmplxParams& params, const Camera& cam, const std::string& name,
                                          const SyntheticKeypointOptions& o, std::mt19937& rng) {
  std::vector<double> verts(size_t(lbs.num_verts()) * 3), joints(size_t(kNumJoints) * 3);
  lbs.forward(params, verts.data(), joints.data(), nullptr);
  const CameraT<double> c = cam.cast<double>();
  KeypointsFrame k;
  k.frame = name;
  k.width = cam.width;
  k.height = cam.height;
  k.people = 1;
  k.score = 0.95;
  k.body.assign(kBodyKeypoints, Keypoint2{});
  std::vector<bool> set(kBodyKeypoints, false);
  std::vector<Vec3d> cam_pts(kBodyKeypoints, Vec3d(0, 0, 0));  // camera space
  namespace bp = blazepose;
  for (const FitVideoPoint& p : points) {
    const double* x = p.joint >= 0 ? &joints[size_t(3 * p.joint)] : &verts[size_t(3 * p.vertex)];
    cam_pts[size_t(p.blazepose)] = c.to_camera(Vec3d(x[0], x[1], x[2]));
    set[size_t(p.blazepose)] = true;
  }
  // BlazePose's hips: shifted towards the shoulders (in 3D, so the 2D points are projections).
  auto mid = [&](int a, int b) { return 0.5 * (cam_pts[size_t(a)] + cam_pts[size_t(b)]); };
  const Vec3d sh = mid(bp::left_shoulder, bp::right_shoulder), hp = mid(bp::left_hip, bp::right_hip);
  for (int h : {bp::left_hip, bp::right_hip}) cam_pts[size_t(h)] += o.hip_shift * (sh - hp);
  for (const FitVideoPoint& p : points) {
    const Vec2<double> px = c.project(cam_pts[size_t(p.blazepose)]);
    k.body[size_t(p.blazepose)] = {px.x, px.y, 0.95};
  }
  // The points the fit does not use: near their neighbours.
  for (int i = 0; i < kBodyKeypoints; ++i) {
    if (set[size_t(i)]) continue;
    int near = bp::nose;
    if (i == bp::left_eye_inner || i == bp::left_eye_outer) near = bp::left_eye;
    if (i == bp::right_eye_inner || i == bp::right_eye_outer) near = bp::right_eye;
    if (i == bp::left_pinky || i == bp::left_index || i == bp::left_thumb) near = bp::left_wrist;
    if (i == bp::right_pinky || i == bp::right_index || i == bp::right_thumb) near = bp::right_wrist;
    k.body[size_t(i)] = k.body[size_t(near)];
    cam_pts[size_t(i)] = cam_pts[size_t(near)];
  }
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Keypoint2& p : k.body) {
    p.x += o.noise_px * g(rng);
    p.y += o.noise_px * g(rng);
    if (u(rng) < o.dropout) {
      p.score = 0.1;
      p.x += 20 * g(rng);
      p.y += 20 * g(rng);
    }
    p.score = std::min(1.0, std::max(0.0, p.score));
    // The reader's limit: within one image size of the frame.
    p.x = std::clamp(p.x, -double(k.width) * kKeypointMargin, double(k.width) * (1 + kKeypointMargin));
    p.y = std::clamp(p.y, -double(k.height) * kKeypointMargin, double(k.height) * (1 + kKeypointMargin));
  }
  if (o.world_noise_m >= 0) {  // after the pixel noise: the same pixels with and without
    const Vec3d centre = mid(bp::left_hip, bp::right_hip);
    for (const Vec3d& p : cam_pts) {
      const Vec3d w = p - centre;
      k.body_world.push_back({w.x + o.world_noise_m * g(rng), w.y + o.world_noise_m * g(rng), w.z + o.world_noise_m * g(rng)});
    }
  }
  return k;
}

// The keypoint JSON of docs/keypoints.md (hands null, no mask).
inline std::string keypoints_json(const KeypointsFrame& k) {
  std::string s = "{\"format\": \"haha-keypoints\", \"version\": 1, \"frame\": \"" + k.frame + "\", \"width\": " +
                  std::to_string(k.width) + ", \"height\": " + std::to_string(k.height) +
                  ", \"people\": " + std::to_string(k.people) + ", \"score\": " + std::to_string(k.score) + ", \"body\": ";
  if (k.body.empty()) {
    s += "null";
  } else {
    s += "[";
    char buf[96];
    for (size_t i = 0; i < k.body.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%s[%.4f, %.4f, %.4f]", i ? ", " : "", k.body[i].x, k.body[i].y, k.body[i].score);
      s += buf;
    }
    s += "]";
  }
  s += ", \"body_world\": ";
  if (k.body_world.empty()) {
    s += "null";
  } else {
    s += "[";
    char buf[96];
    for (size_t i = 0; i < k.body_world.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%s[%.5f, %.5f, %.5f]", i ? ", " : "", k.body_world[i][0], k.body_world[i][1],
                    k.body_world[i][2]);
      s += buf;
    }
    s += "]";
  }
  s += ", \"left_hand\": null, \"right_hand\": null, \"mask\": null, \"model\": \"synthetic\"}";
  return s;
}

}  // namespace haha::test
