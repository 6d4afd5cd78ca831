// s3.prune_cost in the trainer: a prune deletes the Gaussians whose deletion would change
// the frames rendered since the last prune less than the threshold (their removal cost,
// render/gaussian_raster.h), judged on the merged image, not on their opacity; the
// statistic survives a checkpoint.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "body/lbs.h"
#include "core/error.h"
#include "render/avatar_render.h"
#include "train/trainer.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

// Stage 3 with nothing learned (opacity and colour rates 0) and no opacity rule: only the
// image cost deletes, once, after 4 steps of 2 frames (every frame of 4 drawn twice).
TrainConfig cost_only(double prune_cost) {
  TrainConfig c = scene_config(30, 10, 4);
  c.s1.lr_pose = c.s1.lr_pose_fine = 0;  // the frames' own poses, as recomputed below
  c.random_background = false;
  c.s3.lr_opacity = c.s3.lr_color = 0;
  c.s3.prune_threshold = 0;
  c.s3.prune_every = 4;
  c.s3.prune_cost = prune_cost;
  return c;
}

// Removal cost of each Gaussian of `a` in frame f, in millionths of the frame's pixels.
std::vector<float> frame_cost(const Avatar& a, const TrainFrame& f) {
  AvatarViews views(a);
  Lbs<float> lbs(a.body);
  std::vector<float> verts(3 * size_t(a.body.num_verts));
  SmplxParams p = f.params;
  p.betas = a.betas;
  lbs.forward(p, verts.data(), nullptr, nullptr);
  AvatarRenderRequest req = avatar_request(a, views, f.camera, verts.data(), true, true);
  AvatarRenderBuffers buf;
  render_avatar(req, buf);
  const std::vector<float> d_image(buf.image.size(), 0.0f);
  std::vector<float> cost(size_t(a.gaussians.size()), 0.0f), d_op(cost.size());
  AvatarRenderGrads gr;
  gr.opacity = d_op.data();
  gr.removal_cost = cost.data();
  render_avatar_backward(req, buf, d_image.data(), nullptr, nullptr, gr);
  const float ppm = 1e6f / float(f.camera.width * f.camera.height);
  for (float& c : cost) c *= ppm;
  return cost;
}

TEST(TrainerPruneCost, DeletesExactlyWhatCostsLessThanTheThreshold) {
  const std::vector<TrainFrame> frames = scene_frames(scene_truth(), 4, 96);
  // The threshold: the median cost over Gaussians and frames of the stage-3 start.
  Trainer probe(cost_only(1.0), scene_input(frames));
  while (probe.stage() < 3) probe.step();
  const Avatar start = probe.avatar();
  std::vector<std::vector<float>> costs;
  for (const TrainFrame& f : frames) costs.push_back(frame_cost(start, f));
  std::vector<float> all;
  for (const auto& c : costs) all.insert(all.end(), c.begin(), c.end());
  std::nth_element(all.begin(), all.begin() + std::ptrdiff_t(all.size() / 2), all.end());
  const double tau = std::max(1.0f, all[all.size() / 2]);

  Trainer t(cost_only(tau), scene_input(frames));
  while (t.stage() < 3) t.step();
  std::string events;
  while (!t.done()) events += t.step().event;
  EXPECT_NE(events.find("by image cost"), std::string::npos) << events;
  const Avatar end = t.avatar();
  // Gaussians are identified by (face, offset): stage 3 learns nothing here.
  std::set<std::vector<float>> kept;
  for (int i = 0; i < end.gaussians.size(); ++i)
    kept.insert({float(end.gaussians.face[size_t(i)]), end.gaussians.offset[3 * size_t(i)],
                 end.gaussians.offset[3 * size_t(i) + 1], end.gaussians.offset[3 * size_t(i) + 2]});
  // Frames are drawn by epochs: 8 draws of 4 frames see each twice, so the mean over the
  // draws is the mean over the frames.
  int must_go = 0, must_stay = 0;
  for (int i = 0; i < start.gaussians.size(); ++i) {
    double mean = 0;
    for (const auto& c : costs) mean += c[size_t(i)] / double(costs.size());
    const bool is_kept = kept.count({float(start.gaussians.face[size_t(i)]), start.gaussians.offset[3 * size_t(i)],
                                     start.gaussians.offset[3 * size_t(i) + 1],
                                     start.gaussians.offset[3 * size_t(i) + 2]}) > 0;
    if (mean < 0.98 * tau) {
      ++must_go;
      EXPECT_FALSE(is_kept) << "Gaussian " << i << " costs " << mean << " of " << tau;
    }
    if (mean > 1.02 * tau) {
      ++must_stay;
      EXPECT_TRUE(is_kept) << "Gaussian " << i << " costs " << mean << " of " << tau;
    }
  }
  EXPECT_GT(must_go, 5);
  EXPECT_GT(must_stay, 5);
  EXPECT_LT(end.gaussians.size(), start.gaussians.size());
}

TEST(TrainerPruneCost, OffByDefaultAndKeptByACheckpoint) {
  EXPECT_EQ(make_preset("standard").s3.prune_cost, 0.0);
  const std::vector<TrainFrame> frames = scene_frames(scene_truth(), 4, 96);
  TrainConfig c = cost_only(5.0);
  c.s3.prune_every = 0;  // only at the stage end
  Trainer t(c, scene_input(frames));
  while (t.stage() < 3) t.step();
  t.step();
  t.step();
  const TrainCheckpoint ck = t.save();
  ASSERT_EQ(ck.f32.count("prune.removal_cost"), 1u);
  Trainer u(c, scene_input(frames));
  u.load(ck, "checkpoint");
  while (!t.done()) t.step();
  while (!u.done()) u.step();
  EXPECT_EQ(u.avatar().gaussians.offset, t.avatar().gaussians.offset) << "the resumed run prunes the same";
  TrainCheckpoint bad = ck;
  bad.f32["prune.removal_cost"].pop_back();
  Trainer v(c, scene_input(frames));
  EXPECT_THROW(v.load(bad, "checkpoint"), Error);
}

}  // namespace
}  // namespace haha
