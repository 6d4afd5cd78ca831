// Accuracy of the video fit (fit/fit_video.h) on synthetic keypoints: a clip of the
// procedural body (shared betas, a turn from one side to the other, arms and legs moving,
// a sideways walk) seen by a static 512 px camera; its correspondence points projected, 2.5
// px noise, 10 % visibility dropouts, BlazePose-like hips, with or without BlazePose-like
// world points (4.5 cm noise), written as keypoint JSON and read back. The fitted body joints (pelvis + 21) after per-frame similarity Procrustes alignment
// are measured against a 50 mm bar (mean over the frames). With masks (the true body's
// silhouette) the third stage runs and the silhouette IoU is reported.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "fit/fit_video.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/procrustes.h"
#include "support/fit_video_fixtures.h"
#include "train/silhouette_fit.h"

namespace haha {
namespace {

constexpr double kPi = 3.14159265358979323846;

void set(SmplxParams& p, int joint, Vec3d w) {
  for (int c = 0; c < 3; ++c) p.pose[size_t(3 * joint + c)] = float(w[c]);
}

// Frame f of n: camera-frame parameters (Rx(pi): upright, facing the camera at yaw 0).
SmplxParams true_pose(int f, int n, const std::vector<float>& betas) {
  const double s = double(f) / (n - 1), ph = 2 * kPi * s;
  SmplxParams p;
  p.betas = betas;
  const double yaw = -1.0 + 2.0 * s;
  set(p, 0, matrix_to_axis_angle(rodrigues(Vec3d(kPi, 0, 0)) * rodrigues(Vec3d(0, yaw, 0))));
  set(p, 3, Vec3d(0.1 * std::sin(ph), 0.05, 0));
  set(p, 16, matrix_to_axis_angle(rodrigues(Vec3d(0, 0, -1.1 + 0.3 * std::sin(ph))) * rodrigues(Vec3d(-0.4 * std::sin(ph), 0, 0))));
  set(p, 17, matrix_to_axis_angle(rodrigues(Vec3d(0, 0, 0.9 + 0.4 * std::cos(ph))) * rodrigues(Vec3d(0.4 * std::sin(ph), 0, 0))));
  set(p, 18, Vec3d(0, -0.3 - 0.5 * (0.5 + 0.5 * std::sin(2 * ph)), 0));
  set(p, 19, Vec3d(0, 0.4 + 0.4 * (0.5 + 0.5 * std::cos(ph)), 0));
  set(p, 1, Vec3d(-0.35 * std::sin(ph), 0, 0.05));
  set(p, 2, Vec3d(0.35 * std::sin(ph), 0, -0.05));
  set(p, 4, Vec3d(0.15 + 0.4 * (0.5 + 0.5 * std::sin(ph)), 0, 0));
  set(p, 5, Vec3d(0.15 + 0.4 * (0.5 - 0.5 * std::sin(ph)), 0, 0));
  set(p, 15, Vec3d(0.1 * std::sin(ph), 0.2 * std::cos(ph), 0));
  p.transl = {float(-0.3 + 0.6 * s), 0.25f, float(3.3 + 0.2 * std::sin(ph))};
  return p;
}

struct Clip {
  std::vector<SmplxParams> truth;
  std::vector<FitVideoInputFrame> frames;
};

// world_noise_m < 0: no world points (2D only).
Clip make_clip(const BodyModel& body, int n, bool masks, double world_noise_m = -1) {
  Clip c;
  Camera cam;
  cam.width = cam.height = 512;
  cam.fx = cam.fy = 550;
  cam.cx = cam.cy = 256;
  const Lbs<double> lbs(body);
  const Lbs<float> lbs_f(body);
  const std::vector<FitVideoPoint> pts = fit_video_points(body);
  const std::vector<float> betas = {0.8f, -0.6f, 0.4f, 0.3f, -0.4f};
  std::mt19937 rng(17);
  BodySilhouette sil(body);
  std::vector<float> verts(size_t(body.num_verts) * 3);
  for (int f = 0; f < n; ++f) {
    c.truth.push_back(true_pose(f, n, betas));
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d.png", f);
    test::SyntheticKeypointOptions ko;
    ko.world_noise_m = world_noise_m;
    const KeypointsFrame k = test::synthetic_keypoints(lbs, pts, c.truth.back(), cam, name, ko, rng);
    FitVideoInputFrame in;
    in.keypoints = parse_keypoints_json(test::keypoints_json(k), std::string(name) + ".json");
    if (masks) {
      lbs_f.forward(c.truth.back(), verts.data(), nullptr, nullptr);
      const std::vector<float>& img = sil.render(cam, verts.data());
      in.mask = Image(cam.width, cam.height, 1);
      for (size_t q = 0; q < in.mask.data.size(); ++q) in.mask.data[q] = img[3 * q] >= 0.5f ? 1.0f : 0.0f;
    }
    c.frames.push_back(std::move(in));
  }
  return c;
}

// Mean over frames of the Procrustes-aligned error of joints 0..21 (mm), and the raw one.
std::pair<double, double> joint_errors_mm(const BodyModel& body, const Clip& c, const FitVideoResult& r) {
  const Lbs<double> lbs(body);
  std::vector<double> v(size_t(body.num_verts) * 3), jt(size_t(kNumJoints) * 3), jf(jt.size());
  double pa = 0, raw = 0;
  for (size_t i = 0; i < r.kept.size(); ++i) {
    lbs.forward(c.truth[size_t(r.kept[i])], v.data(), jt.data(), nullptr);
    lbs.forward(r.params[i], v.data(), jf.data(), nullptr);
    std::vector<Vec3d> a, b;
    double e = 0;
    for (int j = 0; j < 22; ++j) {
      a.push_back(Vec3d::load(&jt[size_t(3 * j)]));
      b.push_back(Vec3d::load(&jf[size_t(3 * j)]));
      e += norm(a.back() - b.back());
    }
    pa += procrustes_error(a, b);
    raw += e / 22;
  }
  return {1000 * pa / double(r.kept.size()), 1000 * raw / double(r.kept.size())};
}

const BodyModel& body() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 11});
  return b;
}

// One fit of the 32-frame clip: PA-MPJPE (mm) after the checks every run must pass.
double fit_clip(double world_noise_m, const char* what, const FitVideoWeights& w = {}) {
  const int n = 32;
  const Clip c = make_clip(body(), n, false, world_noise_m);
  FitVideoOptions o;
  o.focal_px = 550;
  o.weights = w;
  o.progress = false;
  const auto t0 = std::chrono::steady_clock::now();
  const FitVideoResult r = fit_video(body(), c.frames, o);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const FitVideoFrameReport& f : r.report)
    if (f.dropped) std::printf("%s dropped: %s\n", f.frame.c_str(), f.reason.c_str());
  EXPECT_GE(4 * r.kept.size(), 3 * c.frames.size());  // dropouts may hide both shoulders or both hips
  const auto [pa, raw] = joint_errors_mm(body(), c, r);
  double rp = 0;
  for (int i : r.kept) rp += r.report[size_t(i)].reprojection_px;
  std::printf("video fit, %d frames (%zu kept), %s: PA-MPJPE %.1f mm, MPJPE %.1f mm, reprojection %.2f px, %.1f s\n", n,
              r.kept.size(), what, pa, raw, rp / double(r.kept.size()), secs);
  EXPECT_LT(rp / double(r.kept.size()), 10.0);
  return pa;
}

// The bar is 50 mm. Keypoints only (body_world null), the remaining error is mostly
// the monocular depth ambiguity of the arms (an elbow bent towards the camera vs a straight
// arm swung forward) in the frontal frames: measured 42.2 mm (30 of 32 frames kept; 50.6
// mm with the hips shifted in 2D rather than 3D, the clip's spread; 47.7 mm mean over six
// noise seeds). BlazePose's world points (4.5 cm noise, tests/support/fit_video_fixtures.h)
// tell them apart: measured 22.7 mm (29.3 mm mean over six seeds).
TEST(FitVideoSlow, SyntheticKeypointsWithWorldPointsGiveBodyJointsWithin50mmAfterProcrustes) {
  EXPECT_LE(fit_clip(0.045, "keypoints + world points"), 50.0);
}

TEST(FitVideoSlow, KeypointsOnlyStillFit) {
  EXPECT_LE(fit_clip(-1, "keypoints only"), 60.0);  // regression guard (measured 50.6 mm)
}

TEST(FitVideoSlow, MasksAddTheSilhouetteStageAndReportIou) {
  const Clip c = make_clip(body(), 8, true);
  FitVideoOptions o;
  o.focal_px = 550;
  const auto t0 = std::chrono::steady_clock::now();
  const FitVideoResult r = fit_video(body(), c.frames, o);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto [pa, raw] = joint_errors_mm(body(), c, r);
  double iou = 1;
  for (const FitVideoFrameReport& f : r.report) {
    ASSERT_EQ(std::isfinite(f.silhouette_iou), !f.dropped);  // dropped frames are not fitted
    if (!f.dropped) iou = std::min(iou, f.silhouette_iou);
  }
  std::printf("video fit, 8 frames with masks (%zu kept): PA-MPJPE %.1f mm, MPJPE %.1f mm, lowest silhouette IoU %.3f, %.1f s\n",
              r.kept.size(), pa, raw, iou, secs);
  // Regression guards (measured: 58.0 mm over 6 kept of 8 frames spread over the whole
  // motion, lowest IoU 0.825).
  EXPECT_LE(pa, 65.0);
  EXPECT_GT(iou, 0.75);
}

}  // namespace
}  // namespace haha
