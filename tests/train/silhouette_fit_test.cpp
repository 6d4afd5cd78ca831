// The pose pre-fit to the masks (train/silhouette_fit.h): from a perturbed fit, the body's
// antialiased silhouette is pulled back onto a mask rendered at the true pose, so both the
// silhouette loss and the pose error shrink; steps = 0 leaves the fits untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "body/lbs.h"
#include "render/avatar_render.h"
#include "render/mesh_antialias.h"
#include "support/train_test_scene.h"
#include "train/silhouette_fit.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_camera;
using test::scene_pose;

// The body's coverage at pose p (hard silhouette: a mask as a segmenter gives it).
std::vector<float> mask_at(const SmplxParams& p, const Camera& cam) {
  const BodyModel& body = scene_body();
  Lbs<float> lbs(body);
  std::vector<float> verts(3 * size_t(body.num_verts));
  lbs.forward(p, verts.data(), nullptr, nullptr);
  const float white[3] = {1, 1, 1};
  const TextureView tex{1, 1, 3, white};
  const BodyTopology topology = topology_of(body);
  AvatarRenderRequest req;
  req.camera = &cam;
  req.body = &topology;
  req.verts = verts.data();
  req.texture = &tex;
  AvatarRenderBuffers buf;
  render_avatar(req, buf);
  std::vector<float> m(size_t(cam.width) * cam.height);
  for (size_t q = 0; q < m.size(); ++q) m[q] = buf.image[3 * q];
  return m;
}

double pose_error(const SmplxParams& a, const SmplxParams& b) {
  double s = 0;
  for (int k = 0; k < 3 * 22; ++k) s += std::pow(double(a.pose[size_t(k)]) - b.pose[size_t(k)], 2);
  for (int k = 0; k < 3; ++k) s += std::pow(double(a.transl[size_t(k)]) - b.transl[size_t(k)], 2);
  return std::sqrt(s);
}

TEST(SilhouetteFit, PullsAPerturbedFitOntoTheMask) {
  const Camera cam = scene_camera(64);
  std::vector<TrainFrame> frames;
  std::vector<SmplxParams> truth;
  for (int i = 0; i < 2; ++i) {
    TrainFrame f;
    f.camera = cam;
    truth.push_back(scene_pose(i, 6));
    f.mask = mask_at(truth.back(), cam);
    f.params = truth.back();
    f.params.pose[3 * 16 + 2] += 0.25f;  // left shoulder
    f.params.pose[3 * 2 + 0] -= 0.2f;    // right hip
    f.params.transl[0] += 0.04f;
    frames.push_back(f);
  }
  const std::vector<TrainFrame> before = frames;
  Stage0Config off;
  EXPECT_TRUE(fit_poses_to_masks(scene_body(), frames, off).loss_start.empty());
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].params.pose, before[i].params.pose);

  Stage0Config o;
  o.steps = 60;
  o.lr = 1e-2;
  o.w_inside = 1.0;  // the mask is the body's own: both sides count alike
  std::vector<std::pair<int, int>> calls;
  const SilhouetteFitReport r =
      fit_poses_to_masks(scene_body(), frames, o, [&](int done, int total) { calls.emplace_back(done, total); });
  ASSERT_EQ(r.loss_start.size(), 2u);
  EXPECT_EQ(calls, (std::vector<std::pair<int, int>>{{1, 2}, {2, 2}}));  // progress after each frame
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_LT(r.loss_end[i], 0.5 * r.loss_start[i]) << "frame " << i;
    // What a front view determines: the sideways shift and the arm raised in the image
    // plane; the leg swung towards the camera stays ambiguous and is held by the prior.
    const double e0 = pose_error(before[i].params, truth[i]), e1 = pose_error(frames[i].params, truth[i]);
    EXPECT_LT(e1, e0) << "frame " << i << ": pose error " << e0 << " -> " << e1;
    EXPECT_LT(std::fabs(frames[i].params.transl[0] - truth[i].transl[0]), 0.01) << "frame " << i;
    EXPECT_LT(std::fabs(frames[i].params.pose[3 * 16 + 2] - truth[i].pose[3 * 16 + 2]), 0.6 * 0.25) << "frame " << i;
    EXPECT_EQ(frames[i].params.betas, before[i].params.betas);
  }
}

// The temporal prior's anchors: a turn through +-pi about the vertical axis at a constant
// rate is its own average (the tangent-space mean does not wrap), translations average
// linearly, and independent noise on the fits shrinks.
TEST(SilhouetteFit, TemporalAnchorsAverageNeighboursWithoutWrapping) {
  const int n = 9;
  std::vector<TrainFrame> frames(n);
  for (int i = 0; i < n; ++i) {
    SmplxParams& p = frames[size_t(i)].params;
    const double yaw = 2.6 + 0.2 * i;  // passes pi at i = 3
    const double a = std::remainder(yaw, 2 * M_PI);
    p.pose[1] = float(a);
    p.pose[3 * 4 + 0] = float(0.1 * i);  // a knee bending at a constant rate
    p.transl = {float(0.01 * i), 1.0f, float(i * i) * 0.001f};
  }
  const auto anchors = temporal_pose_anchors(frames, 1);
  ASSERT_EQ(anchors.size(), size_t(n));
  for (int i = 1; i < n - 1; ++i) {
    // Rotations: the same yaw (mod 2 pi) and knee angle.
    const double yaw = std::remainder(2.6 + 0.2 * i, 2 * M_PI);
    EXPECT_NEAR(std::remainder(anchors[size_t(i)][1] - yaw, 2 * M_PI), 0.0, 1e-5) << i;
    EXPECT_NEAR(anchors[size_t(i)][3 * 4], 0.1 * i, 1e-5) << i;
    // Translation: linear in x is kept; z = i^2 / 1000 averages to (i^2 + 2/3) / 1000.
    EXPECT_NEAR(anchors[size_t(i)][66], 0.01 * i, 1e-6);
    EXPECT_NEAR(anchors[size_t(i)][68], (i * i + 2.0 / 3.0) * 0.001, 1e-6);
  }
  // Window 0 returns the fits themselves.
  const auto own = temporal_pose_anchors(frames, 0);
  for (int i = 0; i < n; ++i) EXPECT_FLOAT_EQ(own[size_t(i)][1], frames[size_t(i)].params.pose[1]);
  // Independent noise on a still pose: the +-2 average is closer to the truth.
  std::mt19937 rng(4);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  std::vector<TrainFrame> noisy(40);
  for (TrainFrame& f : noisy)
    for (int k = 0; k < 66; ++k) f.params.pose[size_t(k)] = 0.3f + noise(rng);
  const auto smooth = temporal_pose_anchors(noisy, 2);
  double e_fit = 0, e_anchor = 0;
  for (size_t i = 0; i < noisy.size(); ++i)
    for (int k = 0; k < 66; ++k) {
      e_fit += std::pow(noisy[i].params.pose[size_t(k)] - 0.3, 2);
      e_anchor += std::pow(smooth[i][size_t(k)] - 0.3, 2);
    }
  EXPECT_LT(e_anchor, 0.35 * e_fit);  // ~1/5 for 5 frames, 1/3 at the ends
}

}  // namespace
}  // namespace haha
