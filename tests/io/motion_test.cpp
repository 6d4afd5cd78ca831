// Motions (io/motion.h): AMASS's Z-up world turned to Y-up, checked against rotating the
// LBS-posed body itself; resampling; gender and pose widths.
#include "io/motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "io/npy.h"
#include "support/data_test_util.h"
#include "support/expect_error.h"

namespace haha {
namespace {

using test::expect_error;
using V3 = Vec3<double>;
using M3 = Mat3<double>;

const BodyModel& body() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 3});
  return b;
}

// Rest pelvis of `betas`: the posed pelvis at zero pose and zero transl.
std::array<double, 3> rest_pelvis(const Lbs<double>& lbs, const std::vector<float>& betas) {
  SmplxParams p;
  p.betas = betas;
  std::vector<double> v(size_t(lbs.num_verts()) * 3), j(kNumJoints * 3);
  lbs.forward(p, v.data(), j.data(), nullptr);
  return {j[0], j[1], j[2]};
}

SmplxParams random_params(std::mt19937& rng) {
  std::normal_distribution<float> n(0.0f, 0.3f);
  SmplxParams p;
  for (float& x : p.pose) x = n(rng);
  for (int c = 0; c < 3; ++c) p.transl[size_t(c)] = 2 * n(rng);
  p.betas = {2 * n(rng), 2 * n(rng), 2 * n(rng), 0, 2 * n(rng)};
  return p;
}

class MotionTest : public testutil::TempDirTest {};

TEST_F(MotionTest, ZUpToYUpEqualsRotatingThePosedBody) {
  const Lbs<double> lbs(body());
  std::mt19937 rng(7);
  const M3 R = rodrigues(V3(-M_PI / 2, 0, 0));  // Z up -> Y up
  for (int trial = 0; trial < 4; ++trial) {
    Motion m;
    m.up = {0, 0, 1};
    m.frames = {random_params(rng)};
    const SmplxParams before = m.frames[0];
    const size_t V = size_t(lbs.num_verts());
    std::vector<double> v0(V * 3), v1(V * 3);
    lbs.forward(before, v0.data(), nullptr, nullptr);
    motion_to_y_up(m, rest_pelvis(lbs, before.betas));
    EXPECT_EQ(m.up[1], 1.0);
    lbs.forward(m.frames[0], v1.data(), nullptr, nullptr);
    double worst = 0;
    for (size_t v = 0; v < V; ++v) {
      const V3 want = R * V3(v0[3 * v], v0[3 * v + 1], v0[3 * v + 2]);
      worst = std::max(worst, norm(want - V3(v1[3 * v], v1[3 * v + 1], v1[3 * v + 2])));
    }
    EXPECT_LT(worst, 2e-6) << "trial " << trial;  // float parameters: ~1e-7 relative
    // The pelvis depends on the betas: using the mean shape's pelvis instead moves the body.
    Motion wrong;
    wrong.up = {0, 0, 1};
    wrong.frames = {before};
    wrong.frames[0].betas = {3, 0, 3, 0, 0, 0, 0, 3};  // legs, hips: a pelvis centimetres away
    lbs.forward(wrong.frames[0], v0.data(), nullptr, nullptr);
    motion_to_y_up(wrong, rest_pelvis(lbs, {}));
    lbs.forward(wrong.frames[0], v1.data(), nullptr, nullptr);
    const V3 want0 = R * V3(v0[0], v0[1], v0[2]);
    EXPECT_GT(norm(want0 - V3(v1[0], v1[1], v1[2])), 1e-3) << "trial " << trial;
  }
  // Already Y-up: untouched.
  Motion y;
  y.frames = {random_params(rng)};
  const SmplxParams keep = y.frames[0];
  motion_to_y_up(y, {0.1, 0.2, 0.3});
  EXPECT_EQ(y.frames[0].pose, keep.pose);
  EXPECT_EQ(y.frames[0].transl, keep.transl);
}

TEST_F(MotionTest, UprightAmassBodyStandsUpAndFacesTheFrontCamera) {
  // AMASS stores an upright body with root orientation +90 deg about x, facing -Y, feet on z ~ 0.
  const int T = 3;
  std::vector<double> poses(T * 165, 0.0), trans(T * 3, 0.0);
  for (int t = 0; t < T; ++t) {
    poses[size_t(t) * 165] = M_PI / 2;
    trans[size_t(t) * 3 + 0] = 0.1 * t;  // walks along +x
    trans[size_t(t) * 3 + 2] = 0.95;     // pelvis height
  }
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, 165}));
  z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{120.0}, {}));
  z.set("gender", NpyArray::text("female"));
  z.write(path("walk_stageii.npz"));
  Motion m = read_motion(path("walk_stageii.npz"));
  EXPECT_EQ(m.gender, "female");
  EXPECT_EQ(m.pose_width, 165);
  EXPECT_EQ(m.up[2], 1.0);
  const Lbs<double> lbs(body());
  const std::array<double, 3> J0 = rest_pelvis(lbs, {});
  motion_to_y_up(m, J0);
  std::vector<double> v(size_t(lbs.num_verts()) * 3), j(kNumJoints * 3);
  for (int t = 0; t < T; ++t) {
    lbs.forward(m.frames[size_t(t)], v.data(), j.data(), nullptr);
    auto joint = [&](int k) { return V3(j[3 * k], j[3 * k + 1], j[3 * k + 2]); };
    // Upright: head (15) well above the ankles (7, 8).
    EXPECT_GT(joint(15).y - std::max(joint(7).y, joint(8).y), 1.0);
    // Facing +Z (towards the default front camera, which looks along -Z): the subject's
    // left hip (1) is at +X, and the toes (10, 11) are in front of the ankles.
    EXPECT_GT(joint(1).x - joint(2).x, 0.1);
    EXPECT_GT(joint(10).z - joint(7).z, 0.05);
    // The posed pelvis J0 + trans turns with the world: AMASS x stays x, its z becomes y.
    EXPECT_NEAR(joint(0).x, J0[0] + 0.1 * t, 1e-6);
    EXPECT_NEAR(joint(0).y, J0[2] + 0.95, 1e-6);
    EXPECT_NEAR(joint(0).z, -J0[1], 1e-6);
  }
}

TEST_F(MotionTest, ResampleSlerpsRotationsAndKeepsDuration) {
  Motion m;
  m.fps = 120;
  m.up = {0, 0, 1};
  m.frames.resize(121);  // one second
  for (size_t t = 0; t < m.frames.size(); ++t) {
    const double a = 0.02 * double(t);  // 2.4 rad about z over the second
    m.frames[t].pose[3 * 16 + 2] = float(a);
    m.frames[t].transl[0] = float(0.5 * double(t) / 120.0);
  }
  // 30 fps: every 4th frame exactly.
  const Motion r = resample_motion(m, 30);
  ASSERT_EQ(r.frames.size(), 31u);
  EXPECT_EQ(r.fps, 30);
  EXPECT_EQ(r.up, m.up);
  for (size_t k = 0; k < r.frames.size(); ++k) {
    EXPECT_NEAR(r.frames[k].pose[3 * 16 + 2], m.frames[4 * k].pose[3 * 16 + 2], 1e-5);
    EXPECT_NEAR(r.frames[k].transl[0], m.frames[4 * k].transl[0], 1e-6);
  }
  // 50 fps: between source frames, a rotation about one axis slerps to the linear angle.
  const Motion q = resample_motion(m, 50);
  ASSERT_EQ(q.frames.size(), 51u);
  for (size_t k = 0; k < q.frames.size(); ++k) {
    EXPECT_NEAR(q.frames[k].pose[3 * 16 + 2], 0.02 * 120.0 * double(k) / 50.0, 1e-5) << k;
    EXPECT_NEAR(q.frames[k].transl[0], 0.5 * double(k) / 50.0, 1e-6) << k;
  }
  // Shortest arc across the +-pi wrap: pi - 0.1 about x to -(pi - 0.1) (= pi + 0.1) passes pi.
  Motion w;
  w.fps = 1;
  w.frames.resize(2);
  w.frames[0].pose[0] = float(M_PI - 0.1);
  w.frames[1].pose[0] = float(-(M_PI - 0.1));
  const Motion h = resample_motion(w, 2);
  ASSERT_EQ(h.frames.size(), 3u);
  const M3 mid = rodrigues(V3(h.frames[1].pose[0], h.frames[1].pose[1], h.frames[1].pose[2]));
  const M3 half = rodrigues(V3(M_PI, 0, 0));
  double d = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) d = std::max(d, std::abs(mid.a[a][b] - half.a[a][b]));
  EXPECT_LT(d, 1e-5);
  expect_error([&] { resample_motion(m, 0); }, {"rate"});
}

TEST_F(MotionTest, SmplhWidthUpKeyAndBadGender) {
  Npz z;
  z.set("poses", NpyArray::from(std::vector<float>(2 * 156, 0.0f), {2, 156}));
  z.set("trans", NpyArray::from(std::vector<float>(2 * 3, 0.0f), {2, 3}));
  z.set("mocap_framerate", NpyArray::from(std::vector<double>{60.0}, {}));
  z.set("up", NpyArray::from(std::vector<float>{0, 2, 0}, {3}));
  z.write(path("h.npz"));
  const Motion m = read_motion(path("h.npz"));
  EXPECT_EQ(m.pose_width, 156);
  EXPECT_EQ(m.up, (std::array<double, 3>{0, 1, 0}));
  EXPECT_TRUE(m.gender.empty());
  z.set("gender", NpyArray::text("robot"));
  z.write(path("h.npz"));
  expect_error([&] { read_motion(path("h.npz")); }, {path("h.npz"), "gender", "robot"});
  z.set("gender", NpyArray::text("male"));
  z.set("up", NpyArray::from(std::vector<float>{0, 0, 0}, {3}));
  z.write(path("h.npz"));
  expect_error([&] { read_motion(path("h.npz")); }, {path("h.npz"), "up"});
}

}  // namespace
}  // namespace haha
