// The photometric pose fit against a textured mesh (train/photo_fit.h): frames rendered from
// a textured body at known poses, fits perturbed at the shoulder and in translation; the
// fit learns the texture and pulls the poses back; off leaves them alone; bad frames fail
// with one line naming the frame; the same seed repeats bit for bit.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "support/train_test_scene.h"
#include "train/config.h"
#include "train/photo_fit.h"

namespace haha {
namespace {

using test::scene_body;

// Mean distance of the posed vertices from where the true pose puts them (m): what the
// images see (a shoulder and its collar trade rotations the images cannot tell apart).
double vertex_error(const SmplxParams& a, const SmplxParams& b) {
  const BodyModel& body = scene_body();
  Lbs<float> lbs(body);
  std::vector<float> va(3 * size_t(body.num_verts)), vb(va.size());
  lbs.forward(a, va.data(), nullptr, nullptr);
  lbs.forward(b, vb.data(), nullptr, nullptr);
  double s = 0;
  for (int v = 0; v < body.num_verts; ++v)
    s += std::sqrt(std::pow(va[3 * size_t(v)] - vb[3 * size_t(v)], 2) + std::pow(va[3 * size_t(v) + 1] - vb[3 * size_t(v) + 1], 2) +
                   std::pow(va[3 * size_t(v) + 2] - vb[3 * size_t(v) + 2], 2));
  return s / body.num_verts;
}

// Frames of the scene's textured body alone (no Gaussians) at 64 px, with the fits moved off.
std::vector<TrainFrame> perturbed_frames(std::vector<SmplxParams>* truth) {
  Avatar a = test::scene_truth(32);
  a.gaussians = BoundGaussians();
  std::vector<TrainFrame> frames = test::scene_frames(a, 6, 64);
  for (size_t i = 0; i < frames.size(); ++i) {  // errors that differ from frame to frame, as a fit's do
    TrainFrame& f = frames[i];
    const float sign = i % 2 ? 1.0f : -1.0f;
    truth->push_back(f.params);
    f.params.pose[3 * 16 + 2] += 0.2f * sign;  // left shoulder
    f.params.transl[0] += 0.03f * sign;
  }
  return frames;
}

Stage0Config photo_config(int steps) {
  Stage0Config s0;
  s0.photo.steps = steps;
  s0.photo.lr = 5e-3;
  s0.photo.texture_size = 32;
  s0.photo.levels = "1,2";
  return s0;
}

TEST(PhotoFit, OffLeavesTheFitsAlone) {
  std::vector<SmplxParams> truth;
  std::vector<TrainFrame> frames = perturbed_frames(&truth);
  const std::vector<TrainFrame> before = frames;
  const PhotoFitReport r = fit_poses_to_images(scene_body(), frames, true, Stage0Config{}, 0);
  EXPECT_TRUE(r.texture.empty());
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].params.pose, before[i].params.pose);
    EXPECT_EQ(frames[i].params.transl, before[i].params.transl);
  }
}

TEST(PhotoFit, LearnsTheTextureAndPullsThePosesBack) {
  std::vector<SmplxParams> truth;
  std::vector<TrainFrame> frames = perturbed_frames(&truth);
  double err0 = 0;
  for (size_t i = 0; i < frames.size(); ++i) err0 += vertex_error(frames[i].params, truth[i]);
  std::vector<int> done;
  const PhotoFitReport r = fit_poses_to_images(scene_body(), frames, true, photo_config(800), 0,
                                               [&](int d, int total, double loss) {
                                                 EXPECT_EQ(total, 800);
                                                 EXPECT_TRUE(std::isfinite(loss));
                                                 done.push_back(d);
                                               });
  ASSERT_FALSE(done.empty());
  EXPECT_EQ(done.back(), 800);
  EXPECT_EQ(r.texture_side, 32);
  EXPECT_EQ(r.texture.size(), 32u * 32u * 3u);
  EXPECT_LT(r.loss_end, 0.5 * r.loss_start);
  double err1 = 0;
  for (size_t i = 0; i < frames.size(); ++i) err1 += vertex_error(frames[i].params, truth[i]);
  EXPECT_LT(err1, 0.5 * err0) << "vertex error " << err0 / 6 << " -> " << err1 / 6 << " m per frame";
}

TEST(PhotoFit, SameSeedSameResult) {
  std::vector<SmplxParams> truth;
  std::vector<TrainFrame> a = perturbed_frames(&truth), b = a;
  Stage0Config s0 = photo_config(120);
  s0.photo.lr_betas = 1e-3;
  s0.photo.w_ssim = 0.3;
  s0.photo.w_sobel = 1;
  const PhotoFitReport ra = fit_poses_to_images(scene_body(), a, true, s0, 7);
  const PhotoFitReport rb = fit_poses_to_images(scene_body(), b, true, s0, 7);
  EXPECT_EQ(ra.texture, rb.texture);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].params.pose, b[i].params.pose);
    EXPECT_EQ(a[i].params.betas, a[0].params.betas) << "one shape for the video";
  }
}

TEST(PhotoFit, BadFramesFailNamingTheFrame) {
  std::vector<SmplxParams> truth;
  std::vector<TrainFrame> frames = perturbed_frames(&truth);
  frames[2].mask.clear();
  try {
    fit_poses_to_images(scene_body(), frames, true, photo_config(10), 0);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene frame 2"), std::string::npos) << e.what();
  }
  frames = perturbed_frames(&truth);
  frames[1] = test::scene_frames(test::scene_truth(32), 4, 48)[1];
  EXPECT_THROW(fit_poses_to_images(scene_body(), frames, true, photo_config(10), 0), Error);
}

TEST(PhotoFit, ConfigIsChecked) {
  TrainConfig c = make_preset("tiny");
  c.s0.photo.steps = 10;
  c.s0.photo.warmup = 1.5;
  EXPECT_THROW(validate_config(c), Error);
  c.s0.photo.warmup = 0.2;
  c.s0.photo.levels = "1,x";
  EXPECT_THROW(validate_config(c), Error);
  c.s0.photo.levels = "1,1";
  EXPECT_NO_THROW(validate_config(c));
}

}  // namespace
}  // namespace haha
