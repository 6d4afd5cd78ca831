// s2.coverage in the trainer: after stage 2 the mesh's coverage is learned from the mattes,
// the avatar carries it, stage 3 merges with the cut mesh, and a checkpoint keeps it (or a
// resumed stage-3 run without it learns it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "body/lbs.h"
#include "render/mesh_raster.h"
#include "train/mesh_coverage.h"
#include "train/trainer.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

// The scene's frames with the matte (and the image) cleared below image row `row`: there
// the mesh covers what the mattes call background, as an overshooting surface does.
std::vector<TrainFrame> frames_cut_below(int row) {
  std::vector<TrainFrame> f = scene_frames(scene_truth(), 4, 128);
  for (TrainFrame& t : f)
    for (int y = row; y < t.camera.height; ++y)
      for (int x = 0; x < t.camera.width; ++x) {
        const size_t p = size_t(y) * t.camera.width + x;
        t.mask[p] = 0.0f;
        for (int c = 0; c < 3; ++c) t.rgb[3 * p + c] = 0.0f;
      }
  return f;
}

// Image row of each body vertex in frame 0, NaN for a vertex of no visible face there
// (a vertex no frame draws keeps coverage 1).
std::vector<float> vertex_rows(const TrainFrame& f) {
  const BodyModel& b = scene_body();
  Lbs<float> lbs(b);
  std::vector<float> v(3 * size_t(b.num_verts)), rows(size_t(b.num_verts), NAN);
  lbs.forward(f.params, v.data(), nullptr, nullptr);
  MeshRaster r;
  rasterize_mesh(f.camera, MeshView{v.data(), b.num_verts, b.faces.data(), b.num_faces}, r);
  for (int32_t t : r.tri)
    for (int i = 0; t >= 0 && i < 3; ++i) {
      const int k = b.faces[3 * size_t(t) + size_t(i)];
      rows[size_t(k)] = f.camera.project(f.camera.to_camera(Vec3f::load(&v[3 * size_t(k)]))).y;
    }
  return rows;
}

TEST(TrainerCoverage, TheMeshIsCutWhereTheMattesSayBackground) {
  const std::vector<TrainFrame> frames = frames_cut_below(80);
  TrainConfig c = scene_config(1, 20, 4);
  c.s2.coverage = true;
  c.s1.lr_pose = c.s1.lr_pose_fine = 0;  // the frames' own poses: the coverage is computable here
  Trainer t(c, scene_input(frames));
  while (t.stage() < 3) t.step();
  const Avatar a = t.avatar();
  ASSERT_EQ(a.mesh_coverage.size(), size_t(scene_body().num_verts));
  const std::vector<float> rows = vertex_rows(frames[0]);
  int low = 0, low_cut = 0, high = 0, high_cut = 0;
  for (size_t v = 0; v < rows.size(); ++v) {
    const bool cut = a.mesh_coverage[v] < kCoverageCutoff;
    if (rows[v] > 90) low += 1, low_cut += cut;   // well inside the cleared rows
    if (rows[v] < 70) high += 1, high_cut += cut;  // well outside them
  }
  ASSERT_GT(low, 20);
  ASSERT_GT(high, 20);
  EXPECT_GT(low_cut, low * 3 / 4) << low_cut << " of " << low;  // the rest: other frames see them higher
  EXPECT_LT(high_cut, high / 20 + 1) << high_cut << " of " << high;
  // Exactly the mattes' vote on the training bodies.
  std::vector<std::vector<float>> verts(frames.size());
  std::vector<CoverageFrame> votes;
  Lbs<float> lbs(scene_body());
  for (size_t i = 0; i < frames.size(); ++i) {
    verts[i].resize(3 * size_t(scene_body().num_verts));
    lbs.forward(frames[i].params, verts[i].data(), nullptr, nullptr);
    votes.push_back({&frames[i].camera, verts[i].data(), frames[i].mask.data()});
  }
  const BodyModel& b = scene_body();
  EXPECT_EQ(a.mesh_coverage, learn_mesh_coverage(b.num_verts, b.faces.data(), b.num_faces, votes, kMinCoverageWeight));

  // A checkpoint keeps it; stage 3 finishes with it.
  Trainer u(c, scene_input(frames));
  u.load(t.save(), "checkpoint");
  EXPECT_EQ(u.avatar().mesh_coverage, a.mesh_coverage);
  while (!u.done()) u.step();
  EXPECT_EQ(u.avatar().mesh_coverage, a.mesh_coverage);
  EXPECT_EQ(u.stage1_avatar().mesh_coverage, a.mesh_coverage);  // the naive merge cuts the same mesh
}

TEST(TrainerCoverage, OffByDefaultAndLearnedOnResumingAStage3RunWithout) {
  const std::vector<TrainFrame> frames = frames_cut_below(80);
  TrainConfig c = scene_config(1, 10, 4);
  ASSERT_FALSE(c.s2.coverage);
  Trainer t(c, scene_input(frames));
  while (t.stage() < 3) t.step();
  EXPECT_TRUE(t.avatar().mesh_coverage.empty());
  TrainConfig on = c;
  on.s2.coverage = true;
  Trainer u(on, scene_input(frames));
  u.load(t.save(), "checkpoint");
  EXPECT_EQ(u.avatar().mesh_coverage.size(), size_t(scene_body().num_verts));
  EXPECT_NE(u.step().event.find("mesh coverage:"), std::string::npos) << "the first step reports what the load learned";
}

}  // namespace
}  // namespace haha
