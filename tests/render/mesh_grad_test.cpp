// Mesh rasterizer backward: finite-difference checks in double of barycentrics/depth and of
// attribute interpolation w.r.t. vertex positions (visibility held fixed) and attributes,
// and the float path against the double path on a body-sized mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/parallel.h"
#include "support/render_mesh_fixtures.h"
#include "render/mesh_raster.h"

using namespace haha;
using haha::fixtures::TestMesh;

namespace {

MeshView view(const TestMesh& m) { return {m.verts.data(), m.num_verts(), m.faces.data(), m.num_faces()}; }

// An irregular closed mesh (jittered icosphere) seen by a (40 x 36) * scale camera.
struct Scene {
  TestMesh mesh;
  Camera cam;
  MeshRaster raster;
  std::vector<double> verts;  // double copy
};

Scene make_scene(unsigned seed, int scale = 1) {
  Scene s;
  s.mesh = fixtures::icosphere(1, Vec3d(0, 0, 0), 1.0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-0.08f, 0.08f);
  for (float& v : s.mesh.verts) v += U(rng);
  s.cam = fixtures::look_at_camera(40 * scale, 36 * scale, 30.0 * scale, Vec3d(0.4, 0.5, 2.6), Vec3d(0, 0, 0));
  rasterize_mesh(s.cam, view(s.mesh), s.raster);
  s.verts.assign(s.mesh.verts.begin(), s.mesh.verts.end());
  return s;
}

MeshViewT<double> dview(const Scene& s, const std::vector<double>& v) {
  return {v.data(), s.mesh.num_verts(), s.mesh.faces.data(), s.mesh.num_faces()};
}

// |a - b| <= rtol * (|b| + scale) for every entry (scale = RMS of the analytic gradient, so
// entries that are zero by cancellation are judged on the gradient's own scale).
void expect_close(const std::vector<double>& fd, const std::vector<double>& an, double rtol) {
  double rms = 0;
  for (double v : an) rms += v * v;
  rms = std::sqrt(rms / double(an.size()));
  ASSERT_GT(rms, 0);
  for (size_t i = 0; i < fd.size(); ++i) EXPECT_NEAR(fd[i], an[i], rtol * (std::fabs(an[i]) + rms)) << "entry " << i;
}

}  // namespace

TEST(MeshRasterGrad, BarycentricsAndDepthWrtVertices) {
  const Scene s = make_scene(1);
  const CameraT<double> cam = s.cam.cast<double>();
  const int P = s.raster.num_pixels();
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> wb(size_t(P) * 3), wz(P);
  for (double& w : wb) w = U(rng);
  for (double& w : wz) w = U(rng);
  auto loss = [&](const std::vector<double>& v) {
    std::vector<double> b(size_t(P) * 3), z(P);
    mesh_barycentrics(cam, dview(s, v), s.raster.tri.data(), b.data(), z.data());
    double L = 0;
    for (int p = 0; p < P; ++p) {
      if (s.raster.tri[p] < 0) continue;
      for (int i = 0; i < 3; ++i) L += wb[3 * p + i] * b[3 * p + i];
      L += wz[p] * z[p];
    }
    return L;
  };
  std::vector<double> an(s.verts.size(), 0.0);
  mesh_barycentrics_backward(cam, dview(s, s.verts), s.raster.tri.data(), wb.data(), wz.data(), an.data());
  std::vector<double> fd(s.verts.size());
  const double h = 1e-6;
  for (size_t i = 0; i < s.verts.size(); ++i) {
    std::vector<double> vp = s.verts, vm = s.verts;
    vp[i] += h;
    vm[i] -= h;
    fd[i] = (loss(vp) - loss(vm)) / (2 * h);
  }
  expect_close(fd, an, 1e-6);
  // Every vertex seen by the camera gets a gradient: the test exercises all three corners.
  int nonzero = 0;
  for (double g : an) nonzero += g != 0;
  EXPECT_GT(nonzero, int(an.size()) / 3);
}

TEST(MeshRasterGrad, InterpolateWrtAttributesAndBarycentrics) {
  const Scene s = make_scene(3);
  const int P = s.raster.num_pixels(), C = 3, N = s.mesh.num_uv();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> attr(size_t(N) * C), bary(size_t(P) * 3), g(size_t(P) * C);
  for (double& a : attr) a = U(rng);
  for (double& b : bary) b = U(rng);
  for (double& w : g) w = U(rng);
  auto loss = [&](const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> out(size_t(P) * C);
    interpolate(P, s.raster.tri.data(), b.data(), s.mesh.ft.data(), a.data(), C, out.data());
    double L = 0;
    for (size_t i = 0; i < out.size(); ++i) L += g[i] * out[i];
    return L;
  };
  std::vector<double> ga(attr.size(), 0.0), gb(bary.size(), 7.0);  // gb is overwritten
  interpolate_backward(P, N, s.raster.tri.data(), bary.data(), s.mesh.ft.data(), attr.data(), C, g.data(), ga.data(),
                       gb.data());
  const double h = 1e-6;
  std::vector<double> fa(attr.size());
  for (size_t i = 0; i < attr.size(); ++i) {
    auto ap = attr, am = attr;
    ap[i] += h;
    am[i] -= h;
    fa[i] = (loss(ap, bary) - loss(am, bary)) / (2 * h);
  }
  // The loss is linear: a strided subset of the barycentric entries is enough.
  std::vector<double> fb_sub, gb_sub;
  for (size_t i = 0; i < bary.size(); i += 7) {
    auto bp = bary, bm = bary;
    bp[i] += h;
    bm[i] -= h;
    fb_sub.push_back((loss(attr, bp) - loss(attr, bm)) / (2 * h));
    gb_sub.push_back(gb[i]);
  }
  expect_close(fa, ga, 1e-7);
  expect_close(fb_sub, gb_sub, 1e-7);
  for (int p = 0; p < P; ++p)
    if (s.raster.tri[p] < 0) {
      EXPECT_EQ(gb[3 * p], 0.0);
    }
}

TEST(MeshRasterGrad, InterpolatedAttributeWrtVertexPositions) {
  // out = interpolate(mesh_barycentrics(verts), attr): the pose gradient path. The
  // attribute is per vertex (attr_index = faces) and unrelated to the positions.
  const Scene s = make_scene(5);
  const CameraT<double> cam = s.cam.cast<double>();
  const int P = s.raster.num_pixels(), C = 2, N = s.mesh.num_verts();
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> attr(size_t(N) * C), g(size_t(P) * C);
  for (double& a : attr) a = U(rng);
  for (double& w : g) w = U(rng);
  auto loss = [&](const std::vector<double>& v) {
    std::vector<double> b(size_t(P) * 3), out(size_t(P) * C);
    mesh_barycentrics(cam, dview(s, v), s.raster.tri.data(), b.data(), nullptr);
    interpolate(P, s.raster.tri.data(), b.data(), s.mesh.faces.data(), attr.data(), C, out.data());
    double L = 0;
    for (size_t i = 0; i < out.size(); ++i) L += g[i] * out[i];
    return L;
  };
  std::vector<double> b(size_t(P) * 3), gb(size_t(P) * 3), an(s.verts.size(), 0.0);
  mesh_barycentrics(cam, dview(s, s.verts), s.raster.tri.data(), b.data(), nullptr);
  interpolate_backward(P, N, s.raster.tri.data(), b.data(), s.mesh.faces.data(), attr.data(), C, g.data(),
                       (double*)nullptr, gb.data());
  mesh_barycentrics_backward(cam, dview(s, s.verts), s.raster.tri.data(), gb.data(), (const double*)nullptr, an.data());
  std::vector<double> fd(s.verts.size());
  const double h = 1e-6;
  for (size_t i = 0; i < s.verts.size(); ++i) {
    auto vp = s.verts, vm = s.verts;
    vp[i] += h;
    vm[i] -= h;
    fd[i] = (loss(vp) - loss(vm)) / (2 * h);
  }
  expect_close(fd, an, 1e-6);
}

TEST(MeshRasterGrad, FloatPathMatchesDoubleOnBodySizedMesh) {
  // Small triangles seen from 2.5 m: the float kernels must keep their precision
  // (cancellation-free edge normals) for both values and gradients.
  const TestMesh m = fixtures::body_like_mesh();
  const Camera cam = fixtures::look_at_camera(128, 128, 150, Vec3d(0.4, 0.2, 2.5), Vec3d(0, 0, 0));
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  const int P = r.num_pixels();
  const std::vector<double> vd(m.verts.begin(), m.verts.end());
  const CameraT<double> camd = cam.cast<double>();
  const MeshViewT<double> mv{vd.data(), m.num_verts(), m.faces.data(), m.num_faces()};
  std::vector<double> bd(size_t(P) * 3), zd(P);
  mesh_barycentrics(camd, mv, r.tri.data(), bd.data(), zd.data());
  int covered = 0;
  double bmax = 0, bsum = 0, zmax = 0;
  for (int p = 0; p < P; ++p) {
    if (r.tri[p] < 0) continue;
    ++covered;
    for (int i = 0; i < 3; ++i) {
      const double e = std::fabs(r.bary[3 * p + i] - bd[3 * p + i]);
      bmax = std::max(bmax, e);
      bsum += e * e;
    }
    zmax = std::max(zmax, std::fabs(r.depth[p] - zd[p]) / zd[p]);
  }
  EXPECT_GT(covered, 1500);
  const double brms = std::sqrt(bsum / (3.0 * covered));
  std::printf("float vs double: bary max %.3g rms %.3g, depth max rel %.3g\n", bmax, brms, zmax);
  // The float camera transform rounds positions 2.5 m away by ~1.5e-7 m: for 1 cm
  // triangles that is ~1e-5 in barycentric units and ~1e-7 in relative depth, amplified by
  // 1 / cos at grazing views (the silhouettes of the ellipsoids). Bounds: 3x / 30x that.
  EXPECT_LT(brms, 3e-5);
  EXPECT_LT(bmax, 2e-3);
  EXPECT_LT(zmax, 1e-5);

  std::mt19937 rng(8);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> gbd(size_t(P) * 3), gzd(P);
  for (double& w : gbd) w = U(rng);
  for (double& w : gzd) w = U(rng);
  const std::vector<float> gbf(gbd.begin(), gbd.end()), gzf(gzd.begin(), gzd.end());
  std::vector<double> gvd(vd.size(), 0.0);
  std::vector<float> gvf(vd.size(), 0.0f);
  mesh_barycentrics_backward(camd, mv, r.tri.data(), gbd.data(), gzd.data(), gvd.data());
  mesh_barycentrics_backward(cam, view(m), r.tri.data(), gbf.data(), gzf.data(), gvf.data());
  double num = 0, den = 0;
  for (size_t i = 0; i < gvd.size(); ++i) {
    ASSERT_TRUE(std::isfinite(gvf[i]));
    num += (gvf[i] - gvd[i]) * (gvf[i] - gvd[i]);
    den += gvd[i] * gvd[i];
  }
  // Depth gradients scale with 1 / cos^2: the grazing pixels dominate the norm and carry
  // the float rounding above.
  EXPECT_LT(std::sqrt(num / den), 5e-3);
}

TEST(MeshRasterGrad, GradientsIndependentOfThreadCount) {
  const Scene s = make_scene(9, 3);  // large enough for the threaded path
  const int P = s.raster.num_pixels();
  std::vector<float> gb(size_t(P) * 3, 0.5f), gz(P, -0.25f);
  std::vector<float> g1(s.mesh.verts.size(), 0.0f), g2(s.mesh.verts.size(), 0.0f);
  const int saved = num_threads();
  set_num_threads(1);
  mesh_barycentrics_backward(s.cam, view(s.mesh), s.raster.tri.data(), gb.data(), gz.data(), g1.data());
  set_num_threads(2);
  mesh_barycentrics_backward(s.cam, view(s.mesh), s.raster.tri.data(), gb.data(), gz.data(), g2.data());
  set_num_threads(saved);
  for (size_t i = 0; i < g1.size(); ++i) EXPECT_NEAR(g1[i], g2[i], 1e-4f * (1 + std::fabs(g1[i])));
}

TEST(MeshRasterGrad, AccumulatesIntoExistingGradient) {
  const Scene s = make_scene(10);
  const int P = s.raster.num_pixels();
  std::vector<float> gb(size_t(P) * 3, 0.3f);
  std::vector<float> once(s.mesh.verts.size(), 0.0f), twice(s.mesh.verts.size(), 0.0f);
  mesh_barycentrics_backward(s.cam, view(s.mesh), s.raster.tri.data(), gb.data(), (const float*)nullptr, once.data());
  mesh_barycentrics_backward(s.cam, view(s.mesh), s.raster.tri.data(), gb.data(), (const float*)nullptr, twice.data());
  mesh_barycentrics_backward(s.cam, view(s.mesh), s.raster.tri.data(), gb.data(), (const float*)nullptr, twice.data());
  for (size_t i = 0; i < once.size(); ++i) EXPECT_NEAR(twice[i], 2 * once[i], 1e-5f * (1 + std::fabs(once[i])));
}
