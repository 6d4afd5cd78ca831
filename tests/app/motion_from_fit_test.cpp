// A video's fits to a motion (app/one_euro.h, app/motion_from_fit.h): the filter removes
// jitter from a still signal and keeps a fast one, dropped frames are bridged or cut, the
// motion stands on the ground in the Y-up world, and feet in contact stay put.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "app/motion_from_fit.h"
#include "app/one_euro.h"
#include "body/lbs.h"
#include "body/rotation.h"
#include "data/synth_dataset.h"

namespace haha {
namespace {

using V3 = Vec3<double>;

TEST(OneEuro, StillSignalLosesJitterFastOneKeepsItsSwing) {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0, 0.01);
  std::vector<V3> still, fast;
  for (int t = 0; t < 300; ++t) {
    still.push_back(V3(noise(rng), noise(rng), noise(rng)));
    fast.push_back(V3(0.5 * std::sin(2 * M_PI * 2.0 * t / 30.0), 0, 0));  // 2 Hz, 0.5 m swing
  }
  const std::vector<V3> s = one_euro(still, 30, {}), f = one_euro(fast, 30, {});
  double in = 0, out = 0, peak = 0;
  for (int t = 0; t < 300; ++t) in += norm(still[size_t(t)]), out += norm(s[size_t(t)]);
  for (int t = 30; t < 270; ++t) peak = std::max(peak, f[size_t(t)].x);
  EXPECT_LT(out, 0.4 * in);     // jitter at rest mostly gone
  EXPECT_GT(peak, 0.8 * 0.5);   // a fast move keeps most of its amplitude
  std::vector<Quat<double>> q;
  for (int t = 0; t < 60; ++t) q.push_back(axis_angle_to_quat(V3(0, 0.05 * t, 0)));  // a steady turn
  const std::vector<Quat<double>> fq = one_euro(q, 30, {});
  for (int t = 5; t < 55; ++t) EXPECT_NEAR(quat_to_axis_angle(fq[size_t(t)]).y, 0.05 * t, 0.02) << t;  // no lag
}

// The fit of a person walking in place in front of a camera 3 m away: per frame, pose in
// the camera's OpenCV frame, with jitter and a sideways drift of the root over the clip (as
// a monocular fit's root wanders); frame 5 and the last two dropped.
FitVideoResult walking_fit(const BodyModel& body, double jitter, int T, double drift = 0) {
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0, jitter);
  FitVideoResult r;
  Mat3<double> C = Mat3<double>::identity();
  C.a[1][1] = C.a[2][2] = -1;  // Y-up world <-> OpenCV camera
  const Lbs<double> lbs(body);
  std::vector<double> v(size_t(body.num_verts) * 3), j(size_t(kNumJoints) * 3);
  lbs.forward(SmplxParams{}, v.data(), j.data(), nullptr);
  const V3 J0(j[0], j[1], j[2]);
  for (int t = 0; t < T; ++t) {
    if (t == 5 || t >= T - 2) continue;
    SmplxParams p;
    const double ph = 2 * M_PI * t / 30.0;  // one stride per second
    for (int side = 0; side < 2; ++side) p.pose[size_t(3 * (1 + side))] = float((side ? 1 : -1) * 0.4 * std::sin(ph) + n(rng));
    const Mat3<double> root = C * rodrigues(V3(n(rng), M_PI + n(rng), n(rng)));  // facing the camera
    const V3 w = matrix_to_axis_angle(root);
    for (int c = 0; c < 3; ++c) p.pose[size_t(c)] = float(w[c]);
    const V3 pelvis_cam(drift * t / T + n(rng), 0.2 + n(rng), 3.0 + n(rng));  // the pelvis 3 m ahead
    const V3 tr = pelvis_cam - J0;
    p.transl = {float(tr.x), float(tr.y), float(tr.z)};
    r.kept.push_back(t);
    r.params.push_back(p);
  }
  return r;
}

TEST(MotionFromFit, BridgesCutsStandsAndSmooths) {
  const BodyModel body = synth_body("", BodyResolution::full, 0);
  const int T = 60;
  MotionFromFitReport rep;
  const Motion m = motion_from_fit(walking_fit(body, 0.02, T), T, 30, body, body, {}, &rep);
  EXPECT_EQ(rep.frames, T - 2);
  EXPECT_EQ(rep.bridged, 1);
  EXPECT_EQ(rep.cut, 2);
  EXPECT_NEAR(rep.scale, 1.0, 1e-9);  // the same body plays it
  EXPECT_EQ(m.fps, 30);
  // Upright and on the ground: the pelvis above the feet, the lowest point near the soles.
  const Lbs<double> lbs(body);
  std::vector<double> v(size_t(body.num_verts) * 3), j(size_t(kNumJoints) * 3);
  double rest_sole = INFINITY, lowest = INFINITY;
  lbs.forward(SmplxParams{}, v.data(), j.data(), nullptr);
  for (int i = 0; i < body.num_verts; ++i) rest_sole = std::min(rest_sole, v[size_t(i) * 3 + 1]);
  lbs.forward(m.frames[10], v.data(), j.data(), nullptr);
  for (int i = 0; i < body.num_verts; ++i) lowest = std::min(lowest, v[size_t(i) * 3 + 1]);
  EXPECT_GT(j[1], j[3 * 10 + 1]);
  EXPECT_NEAR(lowest, rest_sole, 0.03);
  // Smoother than the raw fit: the hip's rotation changes less from frame to frame.
  MotionFromFitOptions raw;
  raw.filter.min_cutoff_hz = 1e9;
  raw.lock_feet = false;
  const Motion r = motion_from_fit(walking_fit(body, 0.02, T), T, 30, body, body, raw);
  double dm = 0, dr = 0;
  for (size_t t = 2; t < m.frames.size(); ++t) {
    dm += std::fabs(m.frames[t].pose[3] - 2 * m.frames[t - 1].pose[3] + m.frames[t - 2].pose[3]);
    dr += std::fabs(r.frames[t].pose[3] - 2 * r.frames[t - 1].pose[3] + r.frames[t - 2].pose[3]);
  }
  EXPECT_LT(dm, 0.5 * dr);
}

TEST(MotionFromFit, FeetInContactStayPut) {
  const BodyModel body = synth_body("", BodyResolution::full, 0);
  const int T = 60;
  // Standing still (no stride) while the fitted root drifts 10 cm sideways: both feet are in
  // contact throughout, so only the lock can keep them in place.
  FitVideoResult fit = walking_fit(body, 0.003, T, 0.1);
  for (SmplxParams& p : fit.params) p.pose[3] = p.pose[6] = 0;
  MotionFromFitOptions loose;
  loose.lock_feet = false;
  MotionFromFitOptions locked = loose;
  locked.lock_feet = true;
  MotionFromFitReport rep;
  const Motion a = motion_from_fit(fit, T, 30, body, body, loose), b = motion_from_fit(fit, T, 30, body, body, locked, &rep);
  EXPECT_GE(rep.contacts, 1);
  const Lbs<double> lbs(body);
  std::vector<double> v(size_t(body.num_verts) * 3), j(size_t(kNumJoints) * 3);
  auto travel = [&](const Motion& m) {
    double most = 0, x0 = 0, z0 = 0;
    for (size_t t = 0; t < m.frames.size(); ++t) {
      lbs.forward(m.frames[t], v.data(), j.data(), nullptr);
      if (t == 0) x0 = j[30], z0 = j[32];  // left foot (joint 10)
      most = std::max(most, std::hypot(j[30] - x0, j[32] - z0));
    }
    return most;
  };
  EXPECT_GT(travel(a), 0.05);   // the fit's foot slides with the root
  EXPECT_LT(travel(b), 0.01);   // held: under a centimetre
}

}  // namespace
}  // namespace haha
