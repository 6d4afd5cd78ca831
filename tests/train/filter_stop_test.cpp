// Where the filtering stops (train/filter_stop.h): the rule on hand-made curves (the fewest
// Gaussians within the budget of the best, the ceiling, the fallbacks), its state through a
// checkpoint, and in the trainer: validation views held out, scored at the start and after
// every prune, the run ending on the chosen point's Gaussians, a resumed run repeating the
// uninterrupted one, a corrupt state rejected naming the file.
#include <gtest/gtest.h>

#include "support/expect_error.h"
#include "support/train_test_scene.h"
#include "train/filter_stop.h"
#include "train/train_frame.h"
#include "train/trainer.h"

namespace haha {
namespace {

GaussianParams gaussians(int n) {
  GaussianParams g;
  g.face.assign(size_t(n), 0);
  g.offset.assign(3 * size_t(n), 0.0f);
  g.rotation.assign(4 * size_t(n), 0.0f);
  g.scale_logit.assign(3 * size_t(n), 0.0f);
  g.color_logit.assign(3 * size_t(n), 0.0f);
  g.opacity_logit.assign(size_t(n), float(n));  // tells the states apart
  return g;
}

// Feeds (count, psnr) points in order; returns the stop.
FilterStop run(double stop_db, int max_count, const std::vector<std::pair<int, double>>& pts) {
  FilterStop s;
  s.begin(stop_db, max_count);
  int step = 0;
  for (const auto& [n, psnr] : pts) s.observe(step++ * 100, psnr, gaussians(n));
  return s;
}

TEST(FilterStop, FewestGaussiansWithinTheBudgetOfTheBest) {
  // Quality rises as the filter removes clutter, then falls: the best is at 600, and 400
  // is still within 0.1 dB of it; 200 is not.
  const FilterStop s = run(0.1, 1000, {{1000, 30.0}, {800, 30.2}, {600, 30.3}, {400, 30.22}, {200, 29.9}});
  EXPECT_EQ(s.chosen(), 3);
  ASSERT_NE(s.chosen_gaussians(), nullptr);
  EXPECT_EQ(s.chosen_gaussians()->size(), 400);
  EXPECT_EQ(s.chosen_gaussians()->opacity_logit[0], 400.0f);
}

TEST(FilterStop, TheLastPointIsTheTrainersOwnState) {
  const FilterStop s = run(0.1, 1000, {{1000, 30.0}, {500, 30.05}, {200, 30.1}});
  EXPECT_EQ(s.chosen(), 2);
  EXPECT_EQ(s.chosen_gaussians(), nullptr);  // nothing to restore
}

TEST(FilterStop, TheCeilingRulesOutPointsThatKeepTooMany) {
  // The best is the unfiltered start (above the ceiling of 500): eligible points are judged
  // against it; 450 is within 0.5 dB, 300 is not.
  FilterStop s = run(0.5, 500, {{1000, 31.0}, {450, 30.6}, {300, 30.2}});
  EXPECT_EQ(s.chosen(), 1);
  // None eligible within the budget: the best eligible one.
  s = run(0.1, 500, {{1000, 31.0}, {450, 30.6}, {300, 30.2}});
  EXPECT_EQ(s.chosen(), 1);
  // None eligible at all: the last point.
  s = run(0.1, 100, {{1000, 31.0}, {450, 30.6}, {300, 30.2}});
  EXPECT_EQ(s.chosen(), 2);
  EXPECT_EQ(s.chosen_gaussians(), nullptr);
}

TEST(FilterStop, ALaterBestMovesTheChoiceOn) {
  const FilterStop s = run(0.1, 1000, {{900, 30.0}, {700, 29.95}, {500, 30.4}, {300, 30.1}});
  EXPECT_EQ(s.chosen(), 2);  // 700 was within 0.1 of 30.0, but not of the later 30.4
}

TEST(FilterStop, StateSurvivesACheckpoint) {
  const FilterStop s = run(0.1, 1000, {{1000, 30.0}, {800, 30.2}, {600, 30.3}, {400, 30.22}, {200, 29.9}});
  std::map<std::string, std::vector<double>> f64;
  s.save(f64);
  FilterStop r;
  r.load(f64, "ck.npz");
  for (const char* k : {"within", "best"}) {
    ASSERT_EQ(r.has_kept(k), s.has_kept(k)) << k;
    if (s.has_kept(k)) r.kept(k) = s.kept(k);
  }
  EXPECT_EQ(r.chosen(), s.chosen());
  ASSERT_EQ(r.points().size(), 5u);
  EXPECT_EQ(r.points()[3].gaussians, 400);
  EXPECT_DOUBLE_EQ(r.points()[3].psnr, 30.22);
  EXPECT_EQ(r.chosen_gaussians()->size(), 400);
  f64["filter_stop.state"][3] = 9;  // an index past the points
  test::expect_error([&] { r.load(f64, "ck.npz"); }, {"ck.npz", "filter_stop"});
  f64.erase("filter_stop.points");
  test::expect_error([&] { r.load(f64, "ck.npz"); }, {"ck.npz", "filter_stop: missing"});
}

TEST(FilterStop, HoldOutTakesTheLastOfEachRun) {
  std::vector<TrainFrame> f(7);
  for (size_t i = 0; i < f.size(); ++i) f[i].name = std::to_string(i);
  std::vector<size_t> held;
  const std::vector<TrainFrame> v = hold_out_frames(f, 3, &held);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0].name, "2");
  EXPECT_EQ(v[1].name, "5");
  EXPECT_EQ(held, (std::vector<size_t>{2, 5}));
  ASSERT_EQ(f.size(), 5u);
  EXPECT_EQ(f[2].name, "3");
  std::vector<TrainFrame> two(2);
  EXPECT_TRUE(hold_out_frames(two, 3, &held).empty());
  EXPECT_EQ(two.size(), 2u);
}

// The trainer with validation views: the scene's frames, one in three held out.
struct Validated {
  TrainConfig c;
  TrainInput in;
  Validated() : c(test::scene_config(10, 6, 9)) {
    c.s3.validation_every = 3;
    c.s3.stop_db = 0.05;
    c.s3.max_kept = 1.0;
    static const std::vector<TrainFrame> frames = test::scene_frames(test::scene_truth(), 6, 48);
    in = test::scene_input(frames);
    in.validation = hold_out_frames(in.frames, c.s3.validation_every, nullptr);
  }
};

TEST(FilterStop, TrainerScoresTheRunAndEndsOnTheChoice) {
  Validated v;
  ASSERT_EQ(v.in.validation.size(), 2u);
  Trainer t(v.c, v.in);
  while (!t.done()) t.step();
  const std::vector<FilterStopPoint> pts = t.filter_points();
  ASSERT_EQ(pts.size(), 4u);  // the start and after the prunes at 3, 6, 9
  EXPECT_EQ(pts[0].step, 0);
  EXPECT_EQ(pts[3].step, 9);
  for (size_t i = 1; i < pts.size(); ++i) EXPECT_LE(pts[i].gaussians, pts[i - 1].gaussians);
  for (const FilterStopPoint& p : pts) EXPECT_GT(p.psnr, 10.0);  // a real score of the scene
  const int c = t.filter_choice();
  ASSERT_GE(c, 0);
  EXPECT_EQ(t.num_gaussians(), pts[size_t(c)].gaussians);
  double best = 0;
  for (const FilterStopPoint& p : pts) best = std::max(best, p.psnr);
  EXPECT_GE(pts[size_t(c)].psnr, best - v.c.s3.stop_db);
  for (size_t i = size_t(c) + 1; i < pts.size(); ++i) EXPECT_LT(pts[i].psnr, best - v.c.s3.stop_db);
  EXPECT_EQ(t.validation_params().size(), 2u);
}

TEST(FilterStop, ResumedTrainerRepeatsTheRun) {
  Validated v;
  Trainer ref(v.c, v.in);
  std::vector<TrainCheckpoint> snaps;
  while (!ref.done()) {
    ref.step();
    snaps.push_back(ref.save());
  }
  for (int k : {16, 20}) {  // stage 3 before and after a prune (stages 10 + 6 steps)
    Trainer t(v.c, v.in);
    t.load(snaps[size_t(k - 1)], "snapshot");
    while (!t.done()) t.step();
    EXPECT_EQ(t.filter_choice(), ref.filter_choice()) << k;
    EXPECT_EQ(t.num_gaussians(), ref.num_gaussians()) << k;
    EXPECT_EQ(t.save().f32.at("g.opacity_logit"), ref.save().f32.at("g.opacity_logit")) << k;
  }
  TrainCheckpoint bad = snaps[17];
  bad.f32.erase("validation.pose");
  Trainer t(v.c, v.in);
  test::expect_error([&] { t.load(bad, "ck.npz"); }, {"ck.npz", "validation.pose"});
}

}  // namespace
}  // namespace haha
