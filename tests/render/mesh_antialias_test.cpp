// Silhouette antialiasing (render/mesh_antialias.h): exact coverage for edges parallel to
// the pixel grid, the face adjacency it relies on, finite-difference gradients in double
// (vertices, colours, coverage) on occlusion boundaries and silhouettes, and hard cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/error.h"
#include "render/mesh_antialias.h"
#include "render/mesh_raster.h"
#include "support/render_mesh_fixtures.h"

namespace haha {
namespace {

using fixtures::TestMesh;

// Camera at the origin looking down +z, f = 20 px, W x H.
Camera front_camera(int W, int H) {
  Camera c;
  c.width = W;
  c.height = H;
  c.fx = c.fy = 20;
  c.cx = W / 2.0f;
  c.cy = H / 2.0f;
  c.near_plane = 0.1f;
  c.far_plane = 100;
  return c;
}

// A rectangle facing the camera at depth z spanning pixel coordinates [x0, x1] x [y0, y1]
// (for front_camera), as two triangles sharing a diagonal.
void add_rect(TestMesh& m, const Camera& cam, double x0, double y0, double x1, double y1, double z) {
  const int b = m.num_verts();
  for (auto [px, py] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}) {
    m.verts.push_back(float((px - cam.cx) / cam.fx * z));
    m.verts.push_back(float((py - cam.cy) / cam.fy * z));
    m.verts.push_back(float(z));
  }
  m.faces.insert(m.faces.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

// Forward + a layer: colour per pixel from its triangle (a smooth function of the pixel
// and the face, so neighbours differ), mask = raster coverage.
struct Scene {
  Camera cam;
  TestMesh mesh;
  MeshRaster raster;
  std::vector<int32_t> nbr;
  std::vector<double> color, mask;
  void build() {
    rasterize_mesh(cam, MeshView{mesh.verts.data(), mesh.num_verts(), mesh.faces.data(), mesh.num_faces()}, raster);
    nbr = mesh_face_neighbors(mesh.faces.data(), mesh.num_faces(), mesh.num_verts());
    const int P = cam.width * cam.height;
    color.assign(size_t(P) * 3, 0.0);
    mask.assign(size_t(P), 0.0);
    for (int p = 0; p < P; ++p) {
      if (raster.tri[size_t(p)] < 0) continue;
      mask[size_t(p)] = 1;
      for (int c = 0; c < 3; ++c)
        color[size_t(p) * 3 + c] = 0.5 + 0.4 * std::sin(0.7 * raster.tri[size_t(p)] + 1.3 * c + 0.05 * p);
    }
  }
  AntialiasInputsT<double> inputs(const std::vector<double>& verts, const CameraT<double>& cd) const {
    AntialiasInputsT<double> in;
    in.camera = cd;
    in.mesh = {verts.data(), mesh.num_verts(), mesh.faces.data(), mesh.num_faces()};
    in.neighbors = nbr.data();
    in.tri = raster.tri.data();
    in.depth = raster.depth.data();
    in.color = color.data();
    in.mask = mask.data();
    return in;
  }
};

TEST(MeshAntialias, FaceNeighborsOfClosedMeshBoundaryAndNonManifoldEdges) {
  const TestMesh s = fixtures::icosphere(1);
  const std::vector<int32_t> n = mesh_face_neighbors(s.faces.data(), s.num_faces(), s.num_verts());
  for (int f = 0; f < s.num_faces(); ++f)
    for (int i = 0; i < 3; ++i) {
      const int g = n[size_t(3 * f + i)];
      ASSERT_GE(g, 0) << "closed mesh: every edge has a neighbour";
      int back = 0;
      for (int j = 0; j < 3; ++j) back += n[size_t(3 * g + j)] == f;
      EXPECT_EQ(back, 1) << "face " << g << " lists " << f << " once";
    }
  // Three faces on the edge (0, 1): non-manifold, no neighbour; the other edges are boundaries.
  const std::vector<int32_t> fan = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  const std::vector<int32_t> m = mesh_face_neighbors(fan.data(), 3, 5);
  EXPECT_EQ(m, std::vector<int32_t>(9, -1));
  // Two faces: the shared edge links them.
  const std::vector<int32_t> two = {0, 1, 2, 2, 1, 3};
  EXPECT_EQ(mesh_face_neighbors(two.data(), 2, 4), (std::vector<int32_t>{1, -1, -1, -1, -1, 0}));
  const std::vector<int32_t> bad = {0, 1, 7};
  EXPECT_THROW(mesh_face_neighbors(bad.data(), 1, 3), Error);
}

// An edge parallel to the pixel grid at pixel coordinate e: the pixels it cuts get exactly
// their covered area as coverage, with the occluder's colour; interior pixels (also along
// the rectangle's inner diagonal) are unchanged.
TEST(MeshAntialias, CoverageIsExactForGridAlignedEdges) {
  for (double e : {10.3, 10.7, 10.5}) {
    SCOPED_TRACE(e);
    Scene sc;
    sc.cam = front_camera(24, 24);
    add_rect(sc.mesh, sc.cam, 3.2, 4.6, e, 19.4, 5.0);
    sc.build();
    const CameraT<double> cd = sc.cam.cast<double>();
    std::vector<double> verts(sc.mesh.verts.begin(), sc.mesh.verts.end());
    std::vector<double> col(sc.color.size()), m(sc.mask.size());
    antialias(sc.inputs(verts, cd), col.data(), m.data());
    const int W = sc.cam.width;
    for (int y = 6; y < 18; ++y) {
      const int edge_px = int(std::floor(e));
      // Area of pixel `edge_px` left of the edge.
      EXPECT_NEAR(m[size_t(y * W + edge_px)], e - edge_px, 1e-5) << "row " << y;
      EXPECT_NEAR(m[size_t(y * W + 3)], 0.8, 1e-5) << "left edge at 3.2, row " << y;
      EXPECT_EQ(m[size_t(y * W + edge_px + 1)], 0.0);
      for (int x = 4; x < edge_px; ++x) {
        EXPECT_EQ(m[size_t(y * W + x)], 1.0) << x << "," << y;
        for (int c = 0; c < 3; ++c) EXPECT_EQ(col[size_t(y * W + x) * 3 + c], sc.color[size_t(y * W + x) * 3 + c]);
      }
      // The partly covered pixel shows the rectangle's colour (premultiplied blending).
      const int64_t src = sc.raster.tri[size_t(y * W + edge_px)] >= 0 ? y * W + edge_px : y * W + edge_px - 1;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(col[size_t(y * W + edge_px) * 3 + c], sc.color[size_t(src) * 3 + c], 1e-12);
    }
    // Top edge at y = 4.6 (0.4 of row 4), bottom at 19.4 (0.4 of row 19).
    EXPECT_NEAR(m[size_t(4 * W + 6)], 0.4, 1e-5);
    EXPECT_NEAR(m[size_t(19 * W + 6)], 0.4, 1e-5);
  }
}

// dL/dverts, dL/dcolor, dL/dmask against central differences in double, L = <a, color'> +
// <b, mask'> with random a, b. Visibility is held fixed (as the function defines).
void expect_gradients_match(const Scene& sc, double tol) {
  const CameraT<double> cd = sc.cam.cast<double>();
  const int P = sc.cam.width * sc.cam.height;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> a(size_t(P) * 3), b(static_cast<size_t>(P));
  for (double& x : a) x = u(rng);
  for (double& x : b) x = u(rng);
  std::vector<double> verts(sc.mesh.verts.begin(), sc.mesh.verts.end());
  auto loss = [&](const std::vector<double>& v, const std::vector<double>& color, const std::vector<double>& mask) {
    AntialiasInputsT<double> in = sc.inputs(v, cd);
    in.color = color.data();
    in.mask = mask.data();
    std::vector<double> c(size_t(P) * 3), m(static_cast<size_t>(P));
    antialias(in, c.data(), m.data());
    double s = 0;
    for (size_t i = 0; i < c.size(); ++i) s += a[i] * c[i];
    for (size_t i = 0; i < m.size(); ++i) s += b[i] * m[i];
    return s;
  };
  std::vector<double> gv(verts.size(), 0.0), gc(size_t(P) * 3, 0.0), gm(size_t(P), 0.0);
  antialias_backward(sc.inputs(verts, cd), a.data(), b.data(), gc.data(), gm.data(), gv.data());
  const double h = 1e-6;
  int moved = 0;
  for (size_t i = 0; i < verts.size(); ++i) {
    std::vector<double> vp = verts, vm = verts;
    vp[i] += h;
    vm[i] -= h;
    const double fd = (loss(vp, sc.color, sc.mask) - loss(vm, sc.color, sc.mask)) / (2 * h);
    EXPECT_NEAR(gv[i], fd, tol * (1 + std::fabs(fd))) << "vertex coordinate " << i;
    moved += std::fabs(fd) > 1e-3;
  }
  EXPECT_GT(moved, 3) << "the silhouette must move with the vertices";
  std::vector<double> color = sc.color, mask = sc.mask;
  for (int p = 0; p < P; p += 7) {
    for (int c = 0; c < 3; ++c) {
      std::vector<double> cp = color, cm = color;
      cp[size_t(p) * 3 + c] += h;
      cm[size_t(p) * 3 + c] -= h;
      const double fd = (loss(verts, cp, mask) - loss(verts, cm, mask)) / (2 * h);
      EXPECT_NEAR(gc[size_t(p) * 3 + c], fd, tol * (1 + std::fabs(fd))) << "colour " << p << "," << c;
    }
    std::vector<double> mp = mask, mm = mask;
    mp[size_t(p)] += h;
    mm[size_t(p)] -= h;
    const double fd = (loss(verts, color, mp) - loss(verts, color, mm)) / (2 * h);
    EXPECT_NEAR(gm[size_t(p)], fd, tol * (1 + std::fabs(fd))) << "mask " << p;
  }
}

TEST(MeshAntialias, GradientsMatchFiniteDifferencesOnSilhouettesAndOcclusion) {
  Scene sc;
  sc.cam = fixtures::look_at_camera(28, 24, 30, Vec3d(0.2, 0.3, 3.2), Vec3d(0, 0, 0));
  TestMesh back = fixtures::icosphere(1, Vec3d(0, 0, 0), 0.9);
  TestMesh front = fixtures::icosphere(1, Vec3d(0.35, 0.2, 0.9), 0.35);  // occludes part of `back`
  sc.mesh = back;
  const int b = back.num_verts();
  sc.mesh.verts.insert(sc.mesh.verts.end(), front.verts.begin(), front.verts.end());
  for (int32_t i : front.faces) sc.mesh.faces.push_back(i + b);
  sc.build();
  expect_gradients_match(sc, 1e-5);
}

// A square smaller than a pixel: all four neighbours take part and the separable blend
// gives exactly its area; a sliver and a near-grazing rectangle make large slopes;
// gradients still match.
TEST(MeshAntialias, GradientsMatchOnSubpixelSliverAndGrazingCases) {
  Scene sc;
  sc.cam = front_camera(20, 16);
  add_rect(sc.mesh, sc.cam, 10.3, 8.35, 10.75, 8.7, 4.0);  // covers only the centre of pixel (10, 8)
  sc.build();
  {
    const CameraT<double> cd = sc.cam.cast<double>();
    std::vector<double> verts(sc.mesh.verts.begin(), sc.mesh.verts.end());
    std::vector<double> col(sc.color.size()), m(sc.mask.size());
    antialias(sc.inputs(verts, cd), col.data(), m.data());
    for (double v : m) {
      EXPECT_GE(v, 0.0);
      EXPECT_LE(v, 1.0);
    }
    EXPECT_NEAR(m[size_t(8 * 20 + 10)], 0.45 * 0.35, 1e-5) << "the square's area";
  }
  expect_gradients_match(sc, 1e-5);

  Scene sliver;
  sliver.cam = front_camera(20, 16);
  const int base = 0;
  for (auto [x, y] : {std::pair{2.2, 3.1}, {17.6, 9.4}, {2.4, 3.9}}) {
    const double z = 3.0 + 0.1 * x;
    sliver.mesh.verts.insert(sliver.mesh.verts.end(), {float((x - 10) / 20 * z), float((y - 8) / 20 * z), float(z)});
  }
  sliver.mesh.faces = {base, base + 1, base + 2};
  sliver.build();
  expect_gradients_match(sliver, 1e-5);

  Scene grazing;  // a rectangle seen almost edge-on: depth grows fast across it
  grazing.cam = front_camera(20, 16);
  for (auto [x, y, z] : {std::tuple{-0.6, -0.4, 1.0}, {0.6, -0.4, 1.0}, {0.6, 0.5, 9.0}, {-0.6, 0.5, 9.0}})
    grazing.mesh.verts.insert(grazing.mesh.verts.end(), {float(x), float(y), float(z)});
  grazing.mesh.faces = {0, 1, 2, 0, 2, 3};
  grazing.build();
  expect_gradients_match(grazing, 1e-4);
}

// A triangle with a corner behind the camera: its edges to that corner are skipped (no
// division by z <= 0), every output and gradient is finite and coverage stays in [0, 1].
TEST(MeshAntialias, VerticesBehindTheCameraStayFinite) {
  Scene sc;
  sc.cam = front_camera(20, 16);
  sc.mesh.verts = {-0.5f, -0.4f, 2.0f, 0.6f, -0.3f, 2.5f, 0.1f, 0.5f, -1.0f};
  sc.mesh.faces = {0, 1, 2};
  sc.build();
  const CameraT<double> cd = sc.cam.cast<double>();
  std::vector<double> verts(sc.mesh.verts.begin(), sc.mesh.verts.end());
  const int P = sc.cam.width * sc.cam.height;
  std::vector<double> col(size_t(P) * 3), m(static_cast<size_t>(P));
  antialias(sc.inputs(verts, cd), col.data(), m.data());
  int covered = 0;
  for (int p = 0; p < P; ++p) {
    covered += sc.raster.tri[size_t(p)] >= 0;
    EXPECT_TRUE(std::isfinite(m[size_t(p)]) && m[size_t(p)] >= 0 && m[size_t(p)] <= 1);
  }
  EXPECT_GT(covered, 10);
  std::vector<double> ones(size_t(P) * 3, 1.0), gv(verts.size(), 0.0), gc(size_t(P) * 3, 0.0), gm(size_t(P), 0.0);
  antialias_backward(sc.inputs(verts, cd), ones.data(), ones.data(), gc.data(), gm.data(), gv.data());
  for (double g : gv) EXPECT_TRUE(std::isfinite(g));
  EXPECT_EQ(gv[6], 0.0) << "the corner behind the camera gets no silhouette gradient";
  expect_gradients_match(sc, 1e-5);
}

TEST(MeshAntialias, FloatMatchesDouble) {
  Scene sc;
  sc.cam = fixtures::look_at_camera(32, 32, 36, Vec3d(0, 0.2, 3), Vec3d(0, 0, 0));
  sc.mesh = fixtures::icosphere(2, Vec3d(0, 0, 0), 1.0);
  sc.build();
  const int P = sc.cam.width * sc.cam.height;
  const CameraT<double> cd = sc.cam.cast<double>();
  std::vector<double> verts(sc.mesh.verts.begin(), sc.mesh.verts.end());
  std::vector<double> cold(size_t(P) * 3), md(static_cast<size_t>(P));
  antialias(sc.inputs(verts, cd), cold.data(), md.data());
  std::vector<float> colorf(sc.color.begin(), sc.color.end()), maskf(sc.mask.begin(), sc.mask.end());
  AntialiasInputsT<float> in;
  in.camera = sc.cam;
  in.mesh = {sc.mesh.verts.data(), sc.mesh.num_verts(), sc.mesh.faces.data(), sc.mesh.num_faces()};
  in.neighbors = sc.nbr.data();
  in.tri = sc.raster.tri.data();
  in.depth = sc.raster.depth.data();
  in.color = colorf.data();
  in.mask = maskf.data();
  std::vector<float> colf(size_t(P) * 3), mf(static_cast<size_t>(P));
  antialias(in, colf.data(), mf.data());
  int partial = 0;
  for (int p = 0; p < P; ++p) {
    EXPECT_NEAR(mf[size_t(p)], md[size_t(p)], 1e-4);
    partial += md[size_t(p)] > 0 && md[size_t(p)] < 1;
  }
  EXPECT_GT(partial, 20) << "the sphere's outline is antialiased";
}

TEST(MeshAntialias, BadInputsThrow) {
  AntialiasInputsT<float> in;
  std::vector<float> c(3), m(1);
  EXPECT_THROW(antialias(in, c.data(), m.data()), Error);
}

}  // namespace
}  // namespace haha
