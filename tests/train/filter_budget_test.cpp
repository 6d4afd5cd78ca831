// Stage 3's loss budget (train/filter_budget.h): off it never scales; a view's first visit
// only sets its best; an L2 above the budget fades the opacity weight and one back under it
// restores the weight; its state survives a checkpoint; on the trainer's scene a budget keeps
// more Gaussians than the fixed weight, and a resumed run repeats the uninterrupted one.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "support/train_test_scene.h"
#include "train/filter_budget.h"
#include "train/trainer.h"

namespace haha {
namespace {

TEST(FilterBudget, OffNeverScales) {
  FilterBudget b;
  b.begin(3, 0.0);
  for (int k = 0; k < 50; ++k) b.observe({k % 3}, 1.0 + k);
  EXPECT_EQ(b.scale(), 1.0);
  std::map<std::string, std::vector<double>> f64;
  b.save(f64);
  EXPECT_TRUE(f64.empty());
}

TEST(FilterBudget, FadesAboveTheBudgetAndRecoversBelowIt) {
  FilterBudget b;
  b.begin(2, 0.1);
  b.observe({0}, 0.01);
  b.observe({1}, 0.02);
  EXPECT_EQ(b.scale(), 1.0) << "first visits only set each view's best";
  for (int k = 0; k < 40; ++k) b.observe({k % 2}, (k % 2 ? 0.02 : 0.01) * std::pow(10.0, 0.005));  // +0.05 dB
  EXPECT_EQ(b.scale(), 1.0) << "under the budget";
  for (int k = 0; k < 60; ++k) b.observe({k % 2}, (k % 2 ? 0.02 : 0.01) * std::pow(10.0, 0.05));  // +0.5 dB
  EXPECT_NEAR(b.excess_db(), 0.5, 0.05);
  const double faded = b.scale();
  EXPECT_LT(faded, 0.05);
  EXPECT_GE(faded, FilterBudget::kMinScale);
  for (int k = 0; k < 400; ++k) b.observe({k % 2}, k % 2 ? 0.02 : 0.01);  // back at the best
  EXPECT_EQ(b.scale(), 1.0);
  // A view that is not the run's (a corrupt frame index) is ignored, not a crash.
  b.observe({7}, 1.0);
  b.observe({-1}, 1.0);
  EXPECT_EQ(b.scale(), 1.0);
}

TEST(FilterBudget, StateSurvivesACheckpoint) {
  FilterBudget a;
  a.begin(3, 0.1);
  for (int k = 0; k < 30; ++k) a.observe({k % 3}, 0.01 * (1 + 0.02 * k));
  std::map<std::string, std::vector<double>> f64;
  a.save(f64);
  FilterBudget b;
  b.begin(3, 0.1);
  b.load(f64, "ck.npz");
  for (int k = 30; k < 40; ++k) a.observe({k % 3}, 0.011), b.observe({k % 3}, 0.011);
  EXPECT_EQ(a.scale(), b.scale());
  EXPECT_EQ(a.excess_db(), b.excess_db());
  FilterBudget c;
  c.begin(5, 0.1);  // another number of frames
  EXPECT_THROW(c.load(f64, "ck.npz"), Error);
}

TEST(FilterBudget, KeepsMoreThanTheFixedWeightAndResumesExactly) {
  const std::vector<TrainFrame> frames = test::scene_frames(test::scene_truth(), 6, 64);
  TrainConfig c = test::scene_config(20, 10, 40);
  c.s3.w.opacity = 1e-5;  // a push that deletes all but ~1% of the Gaussians on this scene
  c.s3.prune_every = 10;
  c.s3.lr_opacity = 0.2;  // so 40 steps can take a Gaussian from opacity 0.99 to the threshold
  Trainer fixed(c, test::scene_input(frames));
  while (!fixed.done()) fixed.step();
  c.s3.budget_db = 0.02;
  Trainer ref(c, test::scene_input(frames));
  std::vector<TrainCheckpoint> snaps;
  while (!ref.done()) {
    ref.step();
    snaps.push_back(ref.save());
  }
  EXPECT_GT(ref.num_gaussians(), 2 * fixed.num_gaussians()) << "the budget stops the push where it costs";
  Trainer t(c, test::scene_input(frames));
  t.load(snaps[size_t(20 + 10 + 25 - 1)], "snapshot");  // mid stage 3
  while (!t.done()) t.step();
  EXPECT_EQ(t.save().f32, ref.save().f32);
}

}  // namespace
}  // namespace haha
