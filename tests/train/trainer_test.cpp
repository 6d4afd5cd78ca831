// The trainer's stages on an in-memory scene: each stage improves its render, pose
// refinement moves the fits toward the truth, densification adds Gaussians, filtering
// removes Gaussians where the mesh suffices and keeps those that leave it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.h"
#include "train/evaluate.h"
#include "train/gaussian_params.h"
#include "train/trainer.h"
#include "support/lpips_mini_weights.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

const std::vector<TrainFrame>& frames() {
  static const std::vector<TrainFrame> f = scene_frames(scene_truth(), 6, 64);
  return f;
}

// PSNR of the trainer's current avatar on the training frames (black background, no
// test-time optimisation): Gaussians only in stage 1, textured mesh only in stage 2.
double psnr_now(const Trainer& t, bool mesh, bool gaussians) {
  const Avatar a = t.avatar();
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  return evaluate_variant({"now", &a, mesh, gaussians}, frames(), o).psnr;
}

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

TEST(Trainer, Stage1LowersItsLossAndDensifies) {
  TrainConfig c = scene_config(80, 0, 0);
  c.s1.densify_every = 20;
  c.s1.densify_grad = 2e-4;
  Trainer t(c, scene_input(frames()));
  const int n0 = t.num_gaussians();
  EXPECT_EQ(n0, scene_body().num_faces);  // one per face at start
  const double before = psnr_now(t, false, true);
  while (!t.done()) t.step();
  // (done: the stage-1 state is still the avatar, stages 2 and 3 have no steps)
  EXPECT_GT(psnr_now(t, false, true), before + 2.0);  // measured: +3.1 dB
  EXPECT_TRUE(t.done());
  EXPECT_GT(t.num_gaussians(), n0);  // densification added Gaussians
  const Avatar a = t.stage1_avatar();
  ASSERT_EQ(a.gaussians.size(), t.num_gaussians());
  for (int32_t f : a.gaussians.face) {
    ASSERT_GE(f, 0);
    ASSERT_LT(f, scene_body().num_faces);
  }
  EXPECT_TRUE(all_finite(a.gaussians.offset));
  EXPECT_TRUE(all_finite(a.gaussians.scale));
  // Opacity stays fixed during stage 1.
  for (float o : a.gaussians.opacity) ASSERT_NEAR(o, c.s1.opacity, 1e-5);
}

TEST(Trainer, PoseRefinementMovesTowardTheTruth) {
  // Fits with an offset in transl: stage 1 should pull them back toward the truth.
  std::vector<TrainFrame> f = frames();
  for (TrainFrame& x : f) x.params.transl[0] += 0.03f;
  TrainConfig c = scene_config(80, 0, 0);
  c.s1.lr_pose = 2e-3;
  c.s1.densify_every = 0;
  Trainer t(c, scene_input(f));
  while (!t.done()) t.step();
  const std::vector<SmplxParams> r = t.refined_params();
  double err = 0;
  for (const SmplxParams& p : r) err += std::fabs(p.transl[0]) / r.size();
  EXPECT_LT(err, 0.025);  // started at 0.03
  c.s1.refine_pose = false;
  Trainer t2(c, scene_input(f));
  while (!t2.done()) t2.step();
  for (const SmplxParams& p : t2.refined_params()) EXPECT_FLOAT_EQ(p.transl[0], 0.03f);
}

// s1.lr.pose_final: the pose rates decay log-linearly over stage 1. Adam's first step
// moves every value with a gradient by about the rate, so the per-step change of the
// transl follows the rate: equal at step 1, ~100x smaller at the end for a 100x decay.
TEST(Trainer, PoseRateDecaysToItsFinalValue) {
  std::vector<TrainFrame> f = scene_frames(scene_truth(), 3, 32);
  for (TrainFrame& x : f) x.params.transl[0] += 0.03f;
  auto last_moves = [&](double final_lr) {
    TrainConfig c = scene_config(8, 0, 0);
    c.batch = 3;  // every frame in every step
    c.s1.lr_pose = 2e-3;
    c.s1.lr_pose_final = final_lr;
    c.s1.densify_every = 0;
    Trainer t(c, scene_input(f));
    std::vector<double> moves;  // largest |change| of a transl value per step
    std::vector<SmplxParams> before = t.refined_params();
    while (!t.done()) {
      t.step();
      const std::vector<SmplxParams> now = t.refined_params();
      double m = 0;
      for (size_t i = 0; i < now.size(); ++i)
        for (int k = 0; k < 3; ++k) m = std::max(m, double(std::fabs(now[i].transl[k] - before[i].transl[k])));
      moves.push_back(m);
      before = now;
    }
    return moves;
  };
  const std::vector<double> constant = last_moves(0), same = last_moves(2e-3), decayed = last_moves(2e-5);
  ASSERT_EQ(constant.size(), 8u);
  std::printf("largest transl change per step, constant / decayed rate: first %.3g / %.3g, last %.3g / %.3g\n",
              constant[0], decayed[0], constant.back(), decayed.back());
  EXPECT_EQ(same, constant);  // final = start: the constant rate, bit for bit
  EXPECT_NEAR(decayed[0], constant[0], 1e-9);  // step 1 at the start rate
  EXPECT_GT(constant[0], 1e-3);                // Adam's first step ~ the rate (2e-3)
  EXPECT_LT(decayed.back(), 0.05 * constant.back());
  EXPECT_GT(decayed.back(), 0);
}

TEST(Trainer, Stage2LowersTheTextureLoss) {
  TrainConfig c = scene_config(1, 60, 0);
  Trainer t(c, scene_input(frames()));
  t.step();  // stage 1
  ASSERT_EQ(t.stage(), 2);
  for (int i = 0; i < 5; ++i) t.step();
  const double early = psnr_now(t, true, false);
  while (!t.done()) t.step();
  EXPECT_GT(psnr_now(t, true, false), early + 2.0);  // measured: +7 dB
  const Avatar a = t.avatar();
  ASSERT_EQ(a.texture.width, 32);
  for (float v : a.texture.rgb) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
}

TEST(Trainer, Stage3PrunesWhatTheMeshReplacesAndKeepsWhatLeavesIt) {
  // Stage 1 learns Gaussians for mesh + hair; stage 3 with the opacity regulariser must
  // remove Gaussians, and those bound to the head (the stand-off "hair") must survive at a
  // higher rate than the rest.
  TrainConfig c = scene_config(120, 80, 90);
  c.s1.densify_every = 0;
  c.s3.lr_opacity = 0.2;  // 90 steps reach the threshold from the stage-1 opacity
  Trainer t(c, scene_input(frames()));
  while (!t.done()) t.step();
  const Avatar full = t.stage1_avatar(), filt = t.avatar();
  EXPECT_LT(filt.gaussians.size(), full.gaussians.size());
  for (float o : filt.gaussians.opacity) ASSERT_GE(o, c.s3.prune_threshold);
  const std::vector<int> rf = gaussians_per_region(scene_body(), full.gaussians);
  const std::vector<int> rk = gaussians_per_region(scene_body(), filt.gaussians);
  const int h = int(BodyRegion::head);
  const double head_kept = double(rk[size_t(h)]) / std::max(1, rf[size_t(h)]);
  int rest_full = 0, rest_kept = 0;
  for (size_t k = 0; k < rf.size(); ++k)
    if (int(k) != h) rest_full += rf[k], rest_kept += rk[k];
  const double rest_ratio = double(rest_kept) / std::max(1, rest_full);
  EXPECT_GT(head_kept, rest_ratio) << "head " << head_kept << " rest " << rest_ratio;
}

// The LPIPS-VGG loss on crops around the person (a miniature VGG; the real weights are the
// user's): every stage runs with it, its term is reported and the avatar stays finite; the
// crop size changes the loss (so the crop is in use).
TEST(Trainer, LpipsLossOnPersonCropsRunsInEveryStage) {
  const LpipsWeights vgg = test::make_weights(LpipsBackbone::Vgg16, 5);
  double first_lpips[2] = {0, 0};
  for (int crop : {24, 0}) {
    TrainConfig c = scene_config(4, 4, 4);
    c.s1.w.lpips = c.s2.w.lpips = c.s3.w.lpips = 0.5;
    c.lpips_crop = crop;
    TrainInput in = scene_input(frames());
    in.lpips = &vgg;
    Trainer t(c, in);
    bool seen[4] = {false, false, false, false};
    bool first = true;
    while (!t.done()) {
      const StepReport r = t.step();
      ASSERT_FALSE(r.skipped);
      ASSERT_TRUE(std::isfinite(r.loss.lpips));
      EXPECT_GT(r.loss.lpips, 0.0) << "stage " << r.stage;
      if (first) first_lpips[crop == 0] = r.loss.lpips;
      first = false;
      seen[r.stage] = true;
    }
    EXPECT_TRUE(seen[1] && seen[2] && seen[3]);
    const Avatar a = t.avatar();
    EXPECT_TRUE(all_finite(a.gaussians.offset));
    EXPECT_TRUE(all_finite(a.texture.rgb));
  }
  EXPECT_NE(first_lpips[0], first_lpips[1]);
}

}  // namespace
}  // namespace haha
