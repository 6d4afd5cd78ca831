// The pose pre-fit to the masks (train/silhouette_fit.h): from a perturbed fit, the body's
// antialiased silhouette is pulled back onto a mask rendered at the true pose, so both the
// silhouette loss and the pose error shrink; steps = 0 leaves the fits untouched.
#include <gtest/gtest.h>

#include <cmath>

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
  const SilhouetteFitReport r = fit_poses_to_masks(scene_body(), frames, o);
  ASSERT_EQ(r.loss_start.size(), 2u);
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

}  // namespace
}  // namespace haha
