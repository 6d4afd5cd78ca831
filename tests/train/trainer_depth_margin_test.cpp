// s3.depth_margin means the same in training and in evaluation: the stage-3 loss the
// trainer computes (mesh layer from its cache, Gaussians behind D + margin hidden) equals
// the loss of the evaluation's render of the trainer's avatar, which carries the margin
// (the loader's render of the packed avatar is checked against that render in
// tests/format/avatar_loader_test.cpp).
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

// L2 of the evaluation-path render (avatar_request: the avatar's own margin) of frame f.
double eval_l2(const Avatar& a, const TrainFrame& f, const SmplxParams& p) {
  Lbs<float> lbs(a.body);
  std::vector<float> verts(3 * size_t(a.body.num_verts));
  lbs.forward(p, verts.data(), nullptr, nullptr);
  AvatarViews views(a);
  const AvatarRenderRequest req = avatar_request(a, views, f.camera, verts.data(), true, true);
  AvatarRenderBuffers buf;
  render_avatar(req, buf);
  return l2_loss(buf.image.data(), f.rgb.data(), f.camera.height, f.camera.width);
}

TEST(TrainerDepthMargin, TrainingAndEvaluationHideTheSameGaussians) {
  const TrainFrame f = scene_frames(scene_truth(), 6, 40)[0];
  TrainConfig c = scene_config(10, 5, 1);
  c.batch = 1;
  c.random_background = false;  // black, as the evaluation
  c.s3.depth_margin = 0.05;     // Gaussians up to 5 cm behind the surface show
  Trainer t(c, scene_input({f}));
  while (t.stage() < 3) t.step();
  ASSERT_EQ(t.step_in_stage(), 0);
  const Avatar a = t.avatar();  // the state the stage-3 step renders
  EXPECT_EQ(a.depth_margin, 0.05f);
  const SmplxParams p = t.refined_params()[0];
  const double with_margin = eval_l2(a, f, p);
  Avatar exact = a;
  exact.depth_margin = 0;
  const double without = eval_l2(exact, f, p);
  const StepReport r = t.step();
  ASSERT_EQ(r.stage, 3);
  EXPECT_NEAR(r.loss.l2, with_margin, 1e-6 * with_margin);
  // The margin matters on this avatar (a test that could not tell would be empty): it
  // changes the loss far beyond the agreement above.
  EXPECT_GT(std::fabs(without - with_margin), 2e-5 * with_margin);
  RecordProperty("relative_change_of_the_margin", std::to_string(std::fabs(without - with_margin) / with_margin));
  RecordProperty("relative_train_eval_difference", std::to_string(std::fabs(r.loss.l2 - with_margin) / with_margin));
}

}  // namespace
}  // namespace haha
