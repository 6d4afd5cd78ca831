// The --truth measurement of `haha fit-video` (fit/fit_video_truth.h): the body-joint error
// is 0 for the true fit, unchanged by a different global placement (Procrustes), grows with
// a bent limb; the truth's fits are read from a dataset (params_true preferred), its body
// from DIR/body_model.npz or the fallback; a DIR that is not a dataset or holds fewer frames
// than the video is one error line naming DIR.
#include "fit/fit_video_truth.h"

#include <gtest/gtest.h>

#include "body/procedural_body.h"
#include "body/rotation.h"
#include "data/dataset.h"
#include "io/body_model_io.h"
#include "support/data_test_util.h"

namespace haha {
namespace {

using test::expect_error_at;

const BodyModel& body() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 2});
  return b;
}

SmplxParams pose(double elbow) {
  SmplxParams p;
  p.pose[3 * 18 + 1] = float(elbow);
  p.pose[3 * 1] = 0.3f;
  p.betas = {0.5f, -0.2f};
  return p;
}

TEST(FitVideoTruth, JointErrorIsZeroForTheTruthWhereverItIsPlacedAndGrowsWithABentElbow) {
  const SmplxParams t = pose(-0.2);
  const Lbs<double> lbs(body());
  EXPECT_LT(body_joint_pa_error_mm(lbs, t, lbs, t), 1e-6);
  SmplxParams moved = t;
  moved.pose[0] = 2.5f, moved.pose[1] = -0.4f;  // another global orient and place: aligned away
  moved.transl = {1.0f, -2.0f, 4.0f};
  EXPECT_LT(body_joint_pa_error_mm(lbs, moved, lbs, t), 1e-3);
  const double bent = body_joint_pa_error_mm(lbs, pose(-1.4), lbs, t);
  EXPECT_GT(bent, 5.0);
  EXPECT_LT(bent, 100.0);
}

// The orientation error is that of the body as each camera sees it: a camera turned with the
// body sees no error; the fit turned 10 degrees about the vertical under the same camera, 10.
TEST(FitVideoTruth, OrientErrorIsTheBodysTurnAsItsCameraSeesIt) {
  const SmplxParams t = pose(-0.2);
  Camera cam;
  EXPECT_LT(body_orient_error_deg(cam, t, cam, t), 1e-4);
  SmplxParams turned = t;
  const Mat3<double> yaw = rodrigues(Vec3d(0, 10 * 3.14159265358979323846 / 180, 0));
  const Vec3d w = matrix_to_axis_angle(yaw * rodrigues(Vec3d(t.pose[0], t.pose[1], t.pose[2])));
  for (int c = 0; c < 3; ++c) turned.pose[size_t(c)] = float(w[c]);
  EXPECT_NEAR(body_orient_error_deg(cam, turned, cam, t), 10.0, 1e-3);
  Camera other = cam;  // a camera turned the other way sees the turned body as the truth
  const Mat3<double> back = transpose(yaw);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) other.R.a[i][j] = float(back.a[i][j]);
  EXPECT_LT(body_orient_error_deg(other, turned, cam, t), 1e-3);
  // The body pose and the place do not count.
  SmplxParams bent = pose(-1.4);
  bent.transl = {1.0f, -2.0f, 4.0f};
  EXPECT_LT(body_orient_error_deg(cam, bent, cam, t), 1e-4);
}

class FitVideoTruthDir : public testutil::TempDirTest {
 protected:
  // A dataset of n tiny frames with fits pose(0.1 i) and true fits pose(-0.1 i).
  void write(const std::string& dir, int n, bool with_truth) {
    DatasetWriter w(path(dir), 8, 8, 30, "neutral", "test");
    for (int i = 0; i < n; ++i) {
      DatasetFrame f;
      f.camera.width = f.camera.height = 8;
      f.camera.fx = f.camera.fy = 8, f.camera.cx = f.camera.cy = 4;
      f.params = pose(0.1 * i);
      const SmplxParams t = pose(-0.1 * i);
      w.add(f, Image(8, 8, 3), Image(8, 8, 1), with_truth ? &t : nullptr);
    }
    w.finish();
  }
};

TEST_F(FitVideoTruthDir, ReadsTrueFitsAndTheDatasetsBody) {
  write("a", 3, true);
  FitVideoTruth t = read_fit_video_truth(path("a"), body());
  ASSERT_EQ(t.params.size(), 3u);
  EXPECT_EQ(t.cameras.size(), 3u);
  EXPECT_EQ(t.cameras[2].fx, 8);
  EXPECT_EQ(t.params[2].pose, pose(-0.2).pose);  // params_true, not the fits
  EXPECT_FALSE(t.own_body);
  EXPECT_EQ(t.body.num_verts, body().num_verts);
  check_truth_frames(t, 3);
  expect_error_at(path("a"), [&] { check_truth_frames(t, 4); }, {"fits for 3 frames, the video 4"});

  write("b", 2, false);
  const BodyModel other = make_procedural_body({BodyResolution::low, 5});
  save_body_model(other, path("b/body_model.npz"));
  t = read_fit_video_truth(path("b"), body());
  EXPECT_EQ(t.params[1].pose, pose(0.1).pose);  // no true fits: the dataset's fits
  EXPECT_TRUE(t.own_body);
  EXPECT_EQ(t.body.v_template, other.v_template);
}

TEST_F(FitVideoTruthDir, NotADatasetIsOneLineNamingIt) {
  expect_error_at(path("none"), [&] { read_fit_video_truth(path("none"), body()); }, {"no dataset.json", "--truth"});
}

}  // namespace
}  // namespace haha
