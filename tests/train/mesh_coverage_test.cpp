// The mesh's coverage learned from mattes (train/mesh_coverage.h): each pixel votes its
// matte into the corners of its visible face.
#include <gtest/gtest.h>

#include "body/avatar.h"
#include "core/error.h"
#include "support/render_mesh_fixtures.h"
#include "train/mesh_coverage.h"

using namespace haha;

namespace {

// A 3 x 3 grid of vertices (x, y in {-0.5, 0, 0.5}, z = 0) in 8 faces, and a vertex no face uses.
struct Grid {
  std::vector<float> verts;
  std::vector<int32_t> faces;
  Grid() {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) verts.insert(verts.end(), {-0.5f + 0.5f * float(i), -0.5f + 0.5f * float(j), 0.0f});
    verts.insert(verts.end(), {5.0f, 5.0f, 0.0f});  // vertex 9: never drawn
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int a = j * 3 + i;
        faces.insert(faces.end(), {a, a + 1, a + 4, a, a + 4, a + 3});
      }
  }
  int num_verts() const { return int(verts.size() / 3); }
  int num_faces() const { return int(faces.size() / 3); }
};

Camera camera() { return fixtures::look_at_camera(64, 64, 64, {0, 0, -2}, {0, 0, 0}); }

// Matte 1 on the image's left half (left = true) or right half.
std::vector<float> half_matte(const Camera& cam, bool left) {
  std::vector<float> m(size_t(cam.width) * cam.height, 0.0f);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) m[size_t(y) * cam.width + x] = (x < cam.width / 2) == left ? 1.0f : 0.0f;
  return m;
}

TEST(MeshCoverage, VerticesWhosePixelsAreBackgroundAreCut) {
  const Grid g;
  const Camera cam = camera();
  const std::vector<float> matte = half_matte(cam, true);
  CoverageReport rep;
  const std::vector<float> c =
      learn_mesh_coverage(g.num_verts(), g.faces.data(), g.num_faces(), {{&cam, g.verts.data(), matte.data()}}, 0.5, &rep);
  ASSERT_EQ(c.size(), size_t(g.num_verts()));
  // Which image side world x < 0 lands on decides which column is the person.
  const float xl = cam.project(cam.to_camera(Vec3f(-0.5f, 0, 0))).x;
  const int person = xl < cam.width / 2.0f ? 0 : 2, other = 2 - person;
  for (int j = 0; j < 3; ++j) {
    EXPECT_GT(c[size_t(j * 3 + person)], 0.9f) << "row " << j;
    EXPECT_LT(c[size_t(j * 3 + other)], 0.1f) << "row " << j;
    EXPECT_GT(c[size_t(j * 3 + 1)], 0.2f);  // the middle column straddles the matte's edge
    EXPECT_LT(c[size_t(j * 3 + 1)], 0.8f);
  }
  EXPECT_EQ(c[9], 1.0f) << "a vertex no frame drew is kept";
  EXPECT_EQ(rep.vertices, 10);
  EXPECT_EQ(rep.cut_vertices, 3 + int(c[1] < kCoverageCutoff) + int(c[4] < kCoverageCutoff) + int(c[7] < kCoverageCutoff));
}

TEST(MeshCoverage, FramesVoteByTheirPixels) {
  const Grid g;
  const Camera near_cam = camera();
  const Camera far_cam = fixtures::look_at_camera(64, 64, 64, {0, 0, -4}, {0, 0, 0});  // a quarter of the pixels
  const std::vector<float> ones(64 * 64, 1.0f), zeros(64 * 64, 0.0f);
  const std::vector<float> c = learn_mesh_coverage(
      g.num_verts(), g.faces.data(), g.num_faces(),
      {{&near_cam, g.verts.data(), ones.data()}, {&far_cam, g.verts.data(), zeros.data()}}, 0.5);
  EXPECT_GT(c[4], 0.7f);  // the near frame's 4x pixels outvote the far frame: about 0.8
  EXPECT_LT(c[4], 0.9f);
}

TEST(MeshCoverage, TooLittleWeightKeepsTheVertex) {
  const Grid g;
  const Camera cam = camera();
  const std::vector<float> zeros(64 * 64, 0.0f);
  CoverageReport rep;
  const std::vector<float> c = learn_mesh_coverage(g.num_verts(), g.faces.data(), g.num_faces(),
                                                   {{&cam, g.verts.data(), zeros.data()}}, 1e9, &rep);
  for (float v : c) EXPECT_EQ(v, 1.0f);
  EXPECT_EQ(rep.cut_vertices, 0);
  EXPECT_EQ(rep.unjudged, 9);
}

TEST(MeshCoverage, NoFramesKeepEverythingAndBadFramesThrow) {
  const Grid g;
  const std::vector<float> c = learn_mesh_coverage(g.num_verts(), g.faces.data(), g.num_faces(), {}, 1.0);
  for (float v : c) EXPECT_EQ(v, 1.0f);
  const Camera cam = camera();
  EXPECT_THROW(learn_mesh_coverage(g.num_verts(), g.faces.data(), g.num_faces(), {{&cam, g.verts.data(), nullptr}}, 1.0),
               Error);
}

}  // namespace
