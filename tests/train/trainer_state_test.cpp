// Trainer state and robustness: a restored checkpoint repeats the uninterrupted run bit
// for bit, the non-finite guard skips bad steps and gives up after nan_patience of them,
// hard cases stay finite, bad frames are rejected before any work, ablation switches.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"
#include "support/expect_error.h"
#include "support/train_test_scene.h"
#include "train/gaussian_params.h"
#include "train/trainer.h"

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

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

TEST(Trainer, ResumeRepeatsTheUninterruptedRunExactly) {
  TrainConfig c = scene_config(10, 6, 8);
  c.batch = 2;
  Trainer ref(c, scene_input(frames()));
  std::vector<TrainCheckpoint> snaps;  // state after every step
  while (!ref.done()) {
    ref.step();
    snaps.push_back(ref.save());
  }
  const TrainCheckpoint want = ref.save();
  // Kill after K steps (mid stage 1 between densifications, stage 2, stage 3 after a
  // prune), restore into a fresh trainer, finish, compare every array.
  for (int k : {3, 7, 12, 19}) {
    Trainer t(c, scene_input(frames()));
    t.load(snaps[size_t(k - 1)], "snapshot");
    EXPECT_EQ(t.completed_steps(), k);
    while (!t.done()) t.step();
    const TrainCheckpoint got = t.save();
    for (const auto& [key, v] : want.f32) {
      ASSERT_TRUE(got.f32.count(key)) << key;
      EXPECT_EQ(got.f32.at(key), v) << "k=" << k << " " << key;
    }
    for (const auto& [key, v] : want.i32)
      if (key != "meta.skipped") {
        EXPECT_EQ(got.i32.at(key), v) << "k=" << k << " " << key;
      }
  }
}

TEST(Trainer, NonFiniteGradientsAreSkippedThenStopTheRun) {
  TrainConfig c = scene_config(12, 4, 4);
  c.nan_patience = 3;
  Trainer t(c, scene_input(frames()));
  int calls = 0;
  t.set_gradient_hook([&](int stage, std::vector<float>& g) {
    if (stage == 1 && (calls++ == 2)) g[0] = std::numeric_limits<float>::quiet_NaN();
  });
  std::vector<float> before;
  for (int i = 0; i < 4; ++i) {
    const TrainCheckpoint ck = t.save();
    const StepReport r = t.step();
    if (i == 2) {
      EXPECT_TRUE(r.skipped);
      EXPECT_EQ(t.save().f32.at("g.offset"), ck.f32.at("g.offset"));  // nothing changed
    } else {
      EXPECT_FALSE(r.skipped);
    }
  }
  EXPECT_EQ(t.skipped_steps(), 1);
  // Poison every step: after nan_patience skipped steps in a row, an error.
  t.set_gradient_hook([](int, std::vector<float>& g) { g.back() = std::numeric_limits<float>::infinity(); });
  t.step();
  t.step();
  EXPECT_THROW(t.step(), Error);
  const Avatar a = t.avatar();
  EXPECT_TRUE(all_finite(a.gaussians.offset));
}

TEST(Trainer, HardCasesStayFinite) {
  // A frame whose camera sees nothing of the body, frames repeated in a batch, Gaussians
  // collapsed to the smallest scale: every value stays finite.
  std::vector<TrainFrame> f = frames();
  f[1].camera.t = Vec3f(5.0f, 0.0f, 2.8f);  // body outside the image
  TrainConfig c = scene_config(8, 4, 6);
  c.batch = 7;  // more than the frame count: frames repeat within a step
  c.s1.init_scale = 1e-6;
  Trainer t(c, scene_input(f));
  while (!t.done()) {
    const StepReport r = t.step();
    ASSERT_FALSE(r.skipped);
    ASSERT_TRUE(std::isfinite(r.loss.total));
  }
  const Avatar a = t.avatar();
  EXPECT_TRUE(all_finite(a.gaussians.offset));
  EXPECT_TRUE(all_finite(a.gaussians.rotation));
  EXPECT_TRUE(all_finite(a.texture.rgb));
}

TEST(Trainer, BadFramesAreRejectedBeforeTraining) {
  const TrainConfig c = scene_config(2, 2, 2);
  auto expect_error = [&](std::vector<TrainFrame> f, const std::string& needle) {
    haha::test::expect_error([&] { Trainer t(c, scene_input(f)); }, {needle});
  };
  std::vector<TrainFrame> f = frames();
  f[2].params.pose[10] = std::numeric_limits<float>::quiet_NaN();
  expect_error(f, "scene frame 2: SMPL-X pose value 10 is not finite");
  f = frames();
  f[3].rgb.resize(5);
  expect_error(f, "scene frame 3: RGB buffer");
  f = frames();
  std::fill(f[0].mask.begin(), f[0].mask.end(), 0.0f);
  expect_error(f, "scene frame 0: empty person mask");
  f = frames();
  f[4].camera.width = 65;
  expect_error(f, "scene frame 4: image size 65x64");
  f = frames();
  f[1].rgb[7] = std::numeric_limits<float>::infinity();
  expect_error(f, "scene frame 1: non-finite pixel");
  expect_error({}, "no training frames");
}

TEST(Trainer, AblationSwitchesZeroTheirTerms) {
  TrainConfig c = scene_config(3, 0, 3);
  c.use_sobel = false;
  c.use_dice = false;
  c.use_opacity_reg = false;
  Trainer t(c, scene_input(frames()));
  while (!t.done()) {
    const StepReport r = t.step();
    EXPECT_EQ(r.loss.sobel, 0.0);
    EXPECT_EQ(r.loss.dice, 0.0);
    EXPECT_EQ(r.loss.opacity, 0.0);
    EXPECT_GT(r.loss.l2, 0.0);
  }
}


// A miniature VGG in the documented LPIPS layout (random weights, few channels).
LpipsWeights mini_vgg() {
  const int idx[13] = {0, 2, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28};
  const int taps[5] = {2, 7, 14, 21, 28};
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.f, 1.f);
  LpipsWeights w;
  w.source = "mini.npz";
  int in = 3, tap = 0;
  for (int i : idx) {
    const int out = 3;
    LpipsTensor wt{{out, in, 3, 3}, {}}, bt{{out}, {}};
    for (int k = 0; k < out * in * 9; ++k) wt.data.push_back(0.5f * g(rng));
    for (int k = 0; k < out; ++k) bt.data.push_back(0.05f * g(rng));
    w.tensors["vgg.features." + std::to_string(i) + ".weight"] = wt;
    w.tensors["vgg.features." + std::to_string(i) + ".bias"] = bt;
    in = out;
    if (tap < 5 && i == taps[tap]) {
      w.tensors["vgg.lin." + std::to_string(tap) + ".weight"] = LpipsTensor{{1, out, 1, 1}, {0.5f, 1.0f, 0.7f}};
      ++tap;
    }
  }
  return w;
}

TEST(Trainer, LpipsTermOnlyWithWeights) {
  TrainConfig c = scene_config(3, 3, 0);
  Trainer off(c, scene_input(frames()));
  EXPECT_FALSE(off.lpips_active());
  EXPECT_EQ(off.step().loss.lpips, 0.0);
  const LpipsWeights w = mini_vgg();
  TrainInput in = scene_input(frames());
  in.lpips = &w;
  Trainer on(c, in);
  ASSERT_TRUE(on.lpips_active());
  while (!on.done()) {
    const StepReport r = on.step();
    EXPECT_FALSE(r.skipped);
    EXPECT_GT(r.loss.lpips, 0.0);
  }
}

}  // namespace
}  // namespace haha
