// Motions of the synthetic subject (libhaha/synth/synth_motion.cpp): a full turn, still arms,
// novel test poses, moving fingers, feet on the floor, deterministic, fit noise.
// Low-resolution procedural body.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/error.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/synth_mesh_checks.h"
#include "support/synth_low_subject.h"
#include "synth/synth_internal.h"

namespace haha {
namespace {

using test::low_body;

using test::low_subject;

using haha::test::expect_error;

Mat3<double> joint_rotation(const SmplxParams& p, int j) {
  return rodrigues(Vec3<double>(p.pose[3 * j], p.pose[3 * j + 1], p.pose[3 * j + 2]));
}

// ---------------------------------------------------------------------------------------
// Motions

TEST(SynthMotion, TrainingTurnsOnceAroundTheVerticalAxis) {
  const SynthMotion m = make_synth_motion(low_body(), low_subject(), 12, 4, 0);
  ASSERT_EQ(m.train.size(), 12u);
  ASSERT_EQ(m.test.size(), 4u);
  for (int i = 0; i < 12; ++i) {
    const double a = 2 * synth::kPi * i / 12;
    const Mat3<double> R = joint_rotation(m.train[i], 0);
    const Mat3<double> E = rodrigues(Vec3<double>(0, a, 0));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(R.a[r][c], E.a[r][c], 1e-6) << "frame " << i;
  }
}

TEST(SynthMotion, StillArmsHoldOneArmPoseAndLeaveTheRestOfTheMotion) {
  const SynthMotion swing = make_synth_motion(low_body(), low_subject(), 12, 4, 0);
  const SynthMotion still = make_synth_motion(low_body(), low_subject(), 12, 4, 0, /*still_arms=*/true);
  auto value = [](const SmplxParams& p, int joint, int c) { return p.pose[size_t(3 * joint + c)]; };
  for (int joint : {16, 17, 18, 19}) {  // shoulders, elbows
    double moved = 0;
    for (int i = 1; i < 12; ++i)
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(value(still.train[size_t(i)], joint, c), value(still.train[0], joint, c)) << joint << " frame " << i;
        moved = std::max(moved, double(std::abs(value(swing.train[size_t(i)], joint, c) - value(swing.train[0], joint, c))));
      }
    EXPECT_GT(moved, 0.1) << "joint " << joint << " does not move in the swinging turn";
  }
  for (int i = 0; i < 12; ++i)
    for (int joint = 0; joint < kNumJoints; ++joint) {
      if (joint >= 16 && joint <= 19) continue;
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(value(still.train[size_t(i)], joint, c), value(swing.train[size_t(i)], joint, c)) << joint;
    }
  for (size_t i = 0; i < still.test.size(); ++i)  // the novel test poses are the same
    EXPECT_EQ(still.test[i].pose, swing.test[i].pose);
}

TEST(SynthMotion, EveryTestPoseIsNovel) {
  for (uint64_t seed : {0u, 1u, 7u})
    for (auto [ntrain, ntest] : {std::pair{40, 10}, std::pair{300, 60}}) {
      const SynthMotion m = make_synth_motion(low_body(), low_subject(), ntrain, ntest, seed);
      double gap = 1e9;
      for (const SmplxParams& t : m.test)
        for (const SmplxParams& r : m.train) gap = std::min(gap, pose_distance(t, r));
      EXPECT_GE(gap, kSynthMinPoseGap) << "seed " << seed << ", " << ntrain << "/" << ntest;
    }
  // pose_distance itself: 0 for equal poses, the joint angle for one rotated joint, and
  // blind to the global orientation (the viewpoint).
  SmplxParams a, b;
  EXPECT_EQ(pose_distance(a, a), 0.0);
  b.pose[3 * 4] = 0.5f;
  EXPECT_NEAR(pose_distance(a, b), 0.5, 1e-6);
  b = a;
  b.pose[1] = 2.0f;
  EXPECT_EQ(pose_distance(a, b), 0.0);
}

TEST(SynthMotion, FingersMoveInTrainingAndTestHandsDiffer) {
  const SynthMotion m = make_synth_motion(low_body(), low_subject(), 40, 8, 0);
  // Index and middle fingers curl by most of a radian, the thumb by less.
  for (auto [j, range] : {std::pair{kLeftHandFirst + 1, 0.8}, std::pair{kRightHandFirst + 4, 0.8},
                          std::pair{kLeftHandFirst + 13, 0.3}}) {
    double lo = 1e9, hi = -1e9;
    for (const SmplxParams& p : m.train) {
      const double ang = norm(Vec3<double>(p.pose[3 * j], p.pose[3 * j + 1], p.pose[3 * j + 2]));
      lo = std::min(lo, ang), hi = std::max(hi, ang);
    }
    EXPECT_GT(hi - lo, range) << "joint " << j;
  }
  // Test hands include shapes the training never has: fingers spread apart.
  double max_spread_gap = 0;
  for (const SmplxParams& t : m.test) {
    double best = 1e9;
    for (const SmplxParams& r : m.train) {
      double worst = 0;
      for (int j = kLeftHandFirst; j < kNumJoints; ++j) {
        const Mat3<double> d = transpose(joint_rotation(t, j)) * joint_rotation(r, j);
        worst = std::max(worst, norm(matrix_to_axis_angle(d)));
      }
      best = std::min(best, worst);
    }
    max_spread_gap = std::max(max_spread_gap, best);
  }
  EXPECT_GT(max_spread_gap, 0.2);
}

TEST(SynthMotion, FeetStayOnTheRestFloor) {
  const SynthMotion m = make_synth_motion(low_body(), low_subject(), 8, 4, 3);
  double floor_y = 1e9;
  for (size_t i = 1; i < low_subject().rest_verts.size(); i += 3) floor_y = std::min(floor_y, double(low_subject().rest_verts[i]));
  Lbs<float> lbs(low_body());
  std::vector<float> v(size_t(low_body().num_verts) * 3);
  std::vector<SmplxParams> all = m.train;
  all.insert(all.end(), m.test.begin(), m.test.end());
  for (const SmplxParams& p : all) {
    lbs.forward(p, v.data(), nullptr, nullptr);
    double lo = 1e9;
    for (size_t i = 1; i < v.size(); i += 3) lo = std::min(lo, double(v[i]));
    EXPECT_NEAR(lo, floor_y, 1e-4);
  }
}

TEST(SynthMotion, DeterministicForASeed) {
  const SynthMotion a = make_synth_motion(low_body(), low_subject(), 10, 5, 4);
  const SynthMotion b = make_synth_motion(low_body(), low_subject(), 10, 5, 4);
  const SynthMotion c = make_synth_motion(low_body(), low_subject(), 10, 5, 5);
  bool differs = false;
  for (size_t i = 0; i < a.train.size(); ++i) {
    EXPECT_EQ(a.train[i].pose, b.train[i].pose);
    EXPECT_EQ(a.train[i].transl, b.train[i].transl);
    differs |= a.train[i].pose != c.train[i].pose;
  }
  for (size_t i = 0; i < a.test.size(); ++i) EXPECT_EQ(a.test[i].pose, b.test[i].pose);
  EXPECT_TRUE(differs);
}

TEST(SynthMotion, FitNoiseHasTheRequestedSpreadAndSparesTheEyes) {
  const SynthMotion m = make_synth_motion(low_body(), low_subject(), 40, 10, 0);
  std::vector<SmplxParams> truth = m.train;
  truth.insert(truth.end(), m.test.begin(), m.test.end());
  EXPECT_EQ(perturb_fits(truth, {0, 0}, 1)[3].pose, truth[3].pose);
  const double sigma = 0.03;
  const auto noisy = perturb_fits(truth, {sigma, sigma}, 1);
  const auto again = perturb_fits(truth, {sigma, sigma}, 1);
  const auto other = perturb_fits(truth, {sigma, sigma}, 2);
  double ss = 0;
  int n = 0;
  for (size_t f = 0; f < truth.size(); ++f) {
    EXPECT_EQ(noisy[f].pose, again[f].pose);
    EXPECT_NE(noisy[f].pose, other[f].pose);
    for (int j = 0; j < kNumJoints; ++j)
      for (int c = 0; c < 3; ++c) {
        const double d = double(noisy[f].pose[3 * j + c]) - truth[f].pose[3 * j + c];
        if (j == kLeftEye || j == kRightEye) {
          EXPECT_EQ(d, 0.0);
        } else {
          ss += d * d, ++n;
        }
      }
    for (int c = 0; c < 3; ++c) ss += std::pow(double(noisy[f].transl[c]) - truth[f].transl[c], 2), ++n;
  }
  // n = 8100 samples: the standard deviation estimate is within ~1% (1 sigma) of sigma.
  EXPECT_NEAR(std::sqrt(ss / n), sigma, 0.06 * sigma);
  expect_error([&] { perturb_fits(truth, {-1, 0}, 0); }, "--fit-noise-pose");
  expect_error([&] { perturb_fits(truth, {0, NAN}, 0); }, "--fit-noise-transl");
  // Pose and translation noise are separate: the same draws, each scaled by its sigma.
  const auto pose_only = perturb_fits(truth, {sigma, 0}, 1), transl_only = perturb_fits(truth, {0, 0.5 * sigma}, 1);
  for (size_t f = 0; f < truth.size(); ++f) {
    EXPECT_EQ(pose_only[f].pose, noisy[f].pose);
    EXPECT_EQ(pose_only[f].transl, truth[f].transl);
    EXPECT_EQ(transl_only[f].pose, truth[f].pose);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(transl_only[f].transl[c] - truth[f].transl[c], 0.5 * (noisy[f].transl[c] - truth[f].transl[c]), 1e-6);
  }
}

}  // namespace
}  // namespace haha
