// The rasterizer's coverage cut (render/mesh_raster.h, Avatar::mesh_coverage): a point draws
// where its face's interpolated coverage is >= kCoverageCutoff, and what lies behind a cut
// point shows. Checked against the uncut raster's own barycentrics, pixel by pixel.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "support/render_mesh_fixtures.h"
#include "render/mesh_raster.h"

using namespace haha;
using haha::fixtures::TestMesh;

namespace {

// An axis-aligned square at depth z facing the camera: 4 vertices, 2 faces.
void add_square(TestMesh& m, double half, double z) {
  const int b = m.num_verts();
  for (auto [x, y] : {std::pair{-half, -half}, {half, -half}, {half, half}, {-half, half}})
    m.verts.insert(m.verts.end(), {float(x), float(y), float(z)});
  m.faces.insert(m.faces.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

Camera front_camera(int side) { return fixtures::look_at_camera(side, side, side, {0, 0, -2}, {0, 0, 0}); }

MeshView view(const TestMesh& m, const float* coverage) {
  return {m.verts.data(), m.num_verts(), m.faces.data(), m.num_faces(), coverage};
}

// The coverage a pixel of the uncut raster interpolates.
double interpolated(const MeshRaster& r, const TestMesh& m, const std::vector<float>& cov, size_t p) {
  double c = 0;
  for (int i = 0; i < 3; ++i) c += double(r.bary[3 * p + size_t(i)]) * cov[size_t(m.faces[3 * size_t(r.tri[p]) + size_t(i)])];
  return c;
}

TEST(MeshCoverageCut, DrawsExactlyWhereTheInterpolationReachesTheCutoff) {
  TestMesh m;
  add_square(m, 0.5, 0.0);
  const Camera cam = front_camera(96);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int cut = 0, drawn = 0;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<float> cov(4);
    for (float& c : cov) c = u(rng);
    MeshRaster whole, part;
    rasterize_mesh(cam, view(m, nullptr), whole);
    rasterize_mesh(cam, view(m, cov.data()), part);
    for (size_t p = 0; p < whole.tri.size(); ++p) {
      if (whole.tri[p] < 0) {
        EXPECT_LT(part.tri[p], 0);
        continue;
      }
      const double c = interpolated(whole, m, cov, p);
      if (std::fabs(c - kCoverageCutoff) < 1e-5) continue;  // on the isoline: either is right
      if (c >= kCoverageCutoff) {
        ++drawn;
        ASSERT_EQ(part.tri[p], whole.tri[p]) << "pixel " << p << " interpolates " << c;
        EXPECT_EQ(part.depth[p], whole.depth[p]);
        EXPECT_EQ(part.mask[p], 1.0f);
      } else {
        ++cut;
        ASSERT_EQ(part.tri[p], -1) << "pixel " << p << " interpolates " << c;
        EXPECT_TRUE(std::isinf(part.depth[p]));
        EXPECT_EQ(part.mask[p], 0.0f);
        EXPECT_EQ(part.bary[3 * p], 0.0f);
      }
    }
  }
  EXPECT_GT(cut, 1000);  // both sides seen many times
  EXPECT_GT(drawn, 1000);
}

TEST(MeshCoverageCut, WholeAndEmptyFaces) {
  TestMesh m;
  add_square(m, 0.5, 0.0);
  const Camera cam = front_camera(64);
  MeshRaster whole, r;
  rasterize_mesh(cam, view(m, nullptr), whole);
  const std::vector<float> all = {1, 0.5f, 0.5f, 1};  // every corner at or above the cutoff
  rasterize_mesh(cam, view(m, all.data()), r);
  EXPECT_EQ(r.tri, whole.tri);
  EXPECT_EQ(r.depth, whole.depth);
  const std::vector<float> none = {0.49f, 0, 0.2f, 0.4999f};
  rasterize_mesh(cam, view(m, none.data()), r);
  for (int32_t t : r.tri) EXPECT_EQ(t, -1);
  // One vertex under the cutoff cuts only the faces that use it, only near it.
  const std::vector<float> one = {1, 1, 1, 0};  // vertex 3 is only in face 1
  rasterize_mesh(cam, view(m, one.data()), r);
  int face0 = 0, face0_whole = 0, face1 = 0, face1_whole = 0;
  for (size_t p = 0; p < r.tri.size(); ++p) {
    face0 += r.tri[p] == 0;
    face0_whole += whole.tri[p] == 0;
    face1 += r.tri[p] == 1;
    face1_whole += whole.tri[p] == 1;
  }
  EXPECT_EQ(face0, face0_whole);
  EXPECT_GT(face1, face1_whole / 2);  // (1 - b3) >= 0.5 keeps 3/4 of the face's area
  EXPECT_LT(face1, face1_whole);
}

TEST(MeshCoverageCut, WhatIsBehindACutPointShows) {
  TestMesh m;
  add_square(m, 0.5, 0.0);  // front: faces 0, 1 (vertices 0-3)
  add_square(m, 0.8, 0.5);  // behind: faces 2, 3 (vertices 4-7)
  const Camera cam = front_camera(80);
  const std::vector<float> cov = {0, 0, 0, 0, 1, 1, 1, 1};  // the front square cut away
  MeshRaster r, behind_only;
  rasterize_mesh(cam, view(m, cov.data()), r);
  TestMesh back;
  add_square(back, 0.8, 0.5);
  rasterize_mesh(cam, view(back, nullptr), behind_only);
  for (size_t p = 0; p < r.tri.size(); ++p) {
    ASSERT_EQ(r.tri[p], behind_only.tri[p] < 0 ? -1 : behind_only.tri[p] + 2);
    EXPECT_EQ(r.depth[p], behind_only.depth[p]);
  }
}

TEST(MeshCoverageCut, TheDifferentiablePartsKeepTheirMeaning) {
  // bary/depth of a drawn pixel are those of the uncut raster: the cut only decides visibility.
  TestMesh m;
  add_square(m, 0.5, 0.0);
  const Camera cam = front_camera(48);
  const std::vector<float> cov = {1, 0, 1, 0.7f};
  MeshRaster r;
  rasterize_mesh(cam, view(m, cov.data()), r);
  std::vector<float> bary(r.bary.size()), depth(r.depth.size());
  mesh_barycentrics(cam, view(m, nullptr), r.tri.data(), bary.data(), depth.data());
  EXPECT_EQ(bary, r.bary);
  EXPECT_EQ(depth, r.depth);
}

}  // namespace
