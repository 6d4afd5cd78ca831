// The trainer's densification statistic (3DGS: the mean over views of |dL/d(screen
// centre)| in NDC units, compared with s1.densify_grad): each image axis in its own NDC
// units, and the same value whatever the batch size.
#include <gtest/gtest.h>

#include <cmath>

#include "body/lbs.h"
#include "render/avatar_render.h"
#include "train/losses.h"
#include "train/trainer.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

// A frame of the test scene cropped to 40 x 28 px (rows 6..33): non-square, same pixels.
TrainFrame cropped_frame() {
  TrainFrame f = scene_frames(scene_truth(), 6, 40)[2];
  const int W = 40, top = 6, H = 28;
  f.camera.height = H;
  f.camera.cy -= float(top);
  f.rgb.assign(f.rgb.begin() + 3 * W * top, f.rgb.begin() + 3 * W * (top + H));
  f.mask.assign(f.mask.begin() + W * top, f.mask.begin() + W * (top + H));
  return f;
}

// One stage-1 step without densification (the statistic stays to be read).
TrainConfig one_step_config() {
  TrainConfig c = scene_config(1, 0, 0);
  c.s1.densify_from = 1000;
  c.random_background = false;
  return c;
}

TEST(TrainerDensify, StatisticIsInEachAxisOwnNdcUnits) {
  // L2 only, batch 1: the statistic must be the rasterizer's |(W/2 dL/dx, H/2 dL/dy)| of
  // the screen centres, computed here from the same render.
  const TrainFrame f = cropped_frame();
  const int W = f.camera.width, H = f.camera.height, P = W * H;
  TrainConfig c = one_step_config();
  c.batch = 1;
  c.s1.w = LossWeights{};
  c.s1.w.ssim = c.s1.w.sobel = c.s1.w.lpips = c.s1.w.knn = c.s1.w.dice = 0;
  Trainer t(c, scene_input({f}));
  const Avatar a = t.avatar();
  ASSERT_TRUE(t.refined_params().size() == 1);

  Lbs<float> lbs(a.body);
  std::vector<float> verts(3 * size_t(a.body.num_verts));
  lbs.forward(t.refined_params()[0], verts.data(), nullptr, nullptr);
  AvatarViews views(a);
  AvatarRenderRequest req = avatar_request(a, views, f.camera, verts.data(), false, true);
  AvatarRenderBuffers buf;
  render_avatar(req, buf);
  std::vector<float> d_image(3 * size_t(P), 0.0f);
  l2_loss(buf.image.data(), f.rgb.data(), H, W, static_cast<const float*>(nullptr), d_image.data(),
          float(c.s1.w.l2));
  const int n = a.gaussians.size();
  std::vector<float> own(size_t(n), 0.0f), one(size_t(n), 0.0f);
  AvatarRenderGrads gr;
  gr.means2d_norm_accum = own.data();
  gr.means2d_norm_scale[0] = 0.5f * float(W);
  gr.means2d_norm_scale[1] = 0.5f * float(H);
  render_avatar_backward(req, buf, d_image.data(), nullptr, nullptr, gr);
  gr.means2d_norm_accum = one.data();  // one factor for both axes: what must not come out
  gr.means2d_norm_scale[1] = 0.5f * float(W);
  render_avatar_backward(req, buf, d_image.data(), nullptr, nullptr, gr);

  t.step();
  const std::vector<float> stat = t.densify_statistic();
  ASSERT_EQ(stat.size(), size_t(n));
  float smax = 0;
  for (float s : own) smax = std::max(smax, s);
  ASSERT_GT(smax, 0.0f);
  int differs = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(stat[size_t(i)], own[size_t(i)], 1e-5f * smax) << "Gaussian " << i;
    differs += std::fabs(one[size_t(i)] - own[size_t(i)]) > 1e-3f * smax;
  }
  EXPECT_GT(differs, n / 10);  // the check can tell the two apart
}

TEST(TrainerDensify, StatisticIsTheSameAtAnyBatchSize) {
  // One frame: alone at batch 1, four copies at batch 4 (each drawn once); all loss terms
  // of the preset. The statistic is a per-view gradient, so the two agree.
  const TrainFrame f = scene_frames(scene_truth(), 6, 40)[1];
  std::vector<float> stat[2];
  for (int k = 0; k < 2; ++k) {
    TrainConfig c = one_step_config();
    c.batch = k == 0 ? 1 : 4;
    Trainer t(c, scene_input(std::vector<TrainFrame>(size_t(c.batch), f)));
    t.step();
    stat[k] = t.densify_statistic();
  }
  ASSERT_EQ(stat[0].size(), stat[1].size());
  float smax = 0;
  int seen = 0;
  for (float s : stat[0]) smax = std::max(smax, s), seen += s > 0;
  ASSERT_GT(seen, int(stat[0].size()) / 4);
  for (size_t i = 0; i < stat[0].size(); ++i) EXPECT_NEAR(stat[1][i], stat[0][i], 1e-5f * smax) << "Gaussian " << i;
}

}  // namespace
}  // namespace haha
