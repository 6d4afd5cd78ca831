// render_mesh: the chain vertices -> barycentrics -> UV -> texture -> M (and depth D), its
// finite-difference gradient in double w.r.t. vertices and texels, and the float
// convenience API against that chain.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "support/render_mesh_fixtures.h"
#include "render/render_mesh.h"

using namespace haha;
using haha::fixtures::TestMesh;

namespace {

// Smooth texture (low-frequency colours): bilinear slopes change little between texels, so
// finite differences that cross a texel-centre line stay accurate.
std::vector<float> smooth_texture(int w, int h) {
  std::vector<float> t(size_t(w) * h * 3);
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i)
      for (int c = 0; c < 3; ++c)
        t[(size_t(j) * w + i) * 3 + c] =
            float(0.5 + 0.4 * std::sin(0.21 * i * (c + 1) + 0.5 * c) * std::cos(0.17 * j + 0.3 * c));
  return t;
}

// Double evaluation of L = sum g_M M + sum g_D D over covered pixels with the visibility of
// `tri` held fixed.
struct Chain {
  const TestMesh& m;
  CameraT<double> cam;
  const std::vector<int32_t>& tri;
  TextureViewT<double> tex;
  const std::vector<double>& gM;
  const std::vector<double>& gD;
  double loss(const std::vector<double>& verts, const std::vector<double>& texels) const {
    const int P = cam.width * cam.height;
    TextureViewT<double> t = tex;
    t.data = texels.data();
    std::vector<double> b(size_t(P) * 3), z(P), uv(size_t(P) * 2), M(size_t(P) * 3);
    const std::vector<double> vt(m.uv.begin(), m.uv.end());
    mesh_barycentrics(cam, MeshViewT<double>{verts.data(), m.num_verts(), m.faces.data(), m.num_faces()}, tri.data(),
                      b.data(), z.data());
    interpolate(P, tri.data(), b.data(), m.ft.data(), vt.data(), 2, uv.data());
    sample_texture(t, P, tri.data(), uv.data(), M.data());
    double L = 0;
    for (int p = 0; p < P; ++p) {
      if (tri[p] < 0) continue;
      for (int c = 0; c < 3; ++c) L += gM[3 * p + c] * M[3 * p + c];
      L += gD[p] * z[p];
    }
    return L;
  }
};

}  // namespace

TEST(RenderMesh, ForwardIsTheChainAndBackwardMatchesFiniteDifferences) {
  TestMesh m;
  fixtures::add_ellipsoid(m, Vec3d(0, 0, 0), Vec3d(0.5, 0.7, 0.4), 8, 12, 0.1, 0.1, 0.9, 0.9);
  const Camera cam = fixtures::look_at_camera(48, 48, 50, Vec3d(0.6, 0.4, 2.2), Vec3d(0, 0, 0));
  const int TW = 32, TH = 24;
  const std::vector<float> texf = smooth_texture(TW, TH);
  MeshRenderInput in;
  in.verts = m.verts.data();
  in.num_verts = m.num_verts();
  in.faces = m.faces.data();
  in.num_faces = m.num_faces();
  in.uv = m.uv.data();
  in.num_uv = m.num_uv();
  in.uv_faces = m.ft.data();
  in.texture = TextureView{TW, TH, 3, texf.data()};
  MeshRender r;
  render_mesh(cam, in, r);
  const int P = r.raster.num_pixels();
  int covered = 0;
  for (int p = 0; p < P; ++p) {
    covered += r.raster.tri[p] >= 0;
    for (int c = 0; c < 3; ++c) ASSERT_TRUE(std::isfinite(r.color[3 * p + c]));
    if (r.raster.tri[p] < 0) {
      EXPECT_EQ(r.color[3 * p], 0.0f);
    }
  }
  ASSERT_GT(covered, 400);

  std::mt19937 rng(1);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> gM(size_t(P) * 3), gD(P);
  for (double& v : gM) v = U(rng);
  for (double& v : gD) v = U(rng);
  const std::vector<double> verts(m.verts.begin(), m.verts.end()), texels(texf.begin(), texf.end());
  const Chain chain{m, cam.cast<double>(), r.raster.tri, TextureViewT<double>{TW, TH, 3, nullptr}, gM, gD};

  // Float convenience API.
  const std::vector<float> gMf(gM.begin(), gM.end()), gDf(gD.begin(), gD.end());
  std::vector<float> gv(verts.size(), 0.0f), gt(texels.size(), 0.0f);
  render_mesh_backward(cam, in, r, gMf.data(), gDf.data(), gt.data(), gv.data());

  const double h = 1e-6;
  double num = 0, den = 0;
  for (size_t i = 0; i < verts.size(); ++i) {
    auto vp = verts, vm = verts;
    vp[i] += h;
    vm[i] -= h;
    const double fd = (chain.loss(vp, texels) - chain.loss(vm, texels)) / (2 * h);
    num += (fd - gv[i]) * (fd - gv[i]);
    den += fd * fd;
  }
  // Float analytic gradient vs double finite differences: relative L2 error 1e-4 (float
  // rounding of 1e-5-sized barycentric terms).
  std::printf("vertex gradient: relative L2 error %.3g\n", std::sqrt(num / den));
  EXPECT_LT(std::sqrt(num / den), 1e-4) << "vertex gradient";
  num = den = 0;
  for (size_t i = 0; i < texels.size(); i += 3) {
    auto tp = texels, tm = texels;
    tp[i] += h;
    tm[i] -= h;
    const double fd = (chain.loss(verts, tp) - chain.loss(verts, tm)) / (2 * h);
    num += (fd - gt[i]) * (fd - gt[i]);
    den += fd * fd;
  }
  EXPECT_GT(den, 0);
  std::printf("texture gradient: relative L2 error %.3g\n", std::sqrt(num / den));
  EXPECT_LT(std::sqrt(num / den), 1e-5) << "texture gradient";

  // Texture-only backward (no vertex gradient requested) gives the same texel gradient.
  std::vector<float> gt2(texels.size(), 0.0f);
  render_mesh_backward(cam, in, r, gMf.data(), nullptr, gt2.data(), nullptr);
  for (size_t i = 0; i < gt.size(); ++i) EXPECT_FLOAT_EQ(gt2[i], gt[i]);
}

TEST(RenderMesh, BadInputThrows) {
  TestMesh m;
  fixtures::add_ellipsoid(m, Vec3d(0, 0, 0), Vec3d(0.5, 0.5, 0.5), 4, 6);
  const Camera cam = fixtures::look_at_camera(16, 16, 20, Vec3d(0, 0, 2), Vec3d(0, 0, 0));
  const std::vector<float> tex(4 * 4 * 3, 0.5f);
  MeshRenderInput in;
  in.verts = m.verts.data();
  in.num_verts = m.num_verts();
  in.faces = m.faces.data();
  in.num_faces = m.num_faces();
  in.uv = m.uv.data();
  in.num_uv = m.num_uv();
  in.uv_faces = m.ft.data();
  in.texture = TextureView{4, 4, 3, tex.data()};
  MeshRender r;
  EXPECT_NO_THROW(render_mesh(cam, in, r));
  in.num_uv = 3;  // ft indices now out of range
  EXPECT_THROW(render_mesh(cam, in, r), Error);
  in.num_uv = m.num_uv();
  in.texture.width = 0;
  EXPECT_THROW(render_mesh(cam, in, r), Error);
}

TEST(RenderMesh, DepthOnlyBackwardEqualsBarycentricBackward) {
  TestMesh m;
  fixtures::add_ellipsoid(m, Vec3d(0, 0, 0), Vec3d(0.5, 0.6, 0.4), 6, 10);
  const Camera cam = fixtures::look_at_camera(32, 32, 35, Vec3d(0.3, 0.2, 2.0), Vec3d(0, 0, 0));
  const std::vector<float> tex(8 * 8 * 3, 0.5f);
  MeshRenderInput in;
  in.verts = m.verts.data();
  in.num_verts = m.num_verts();
  in.faces = m.faces.data();
  in.num_faces = m.num_faces();
  in.uv = m.uv.data();
  in.num_uv = m.num_uv();
  in.uv_faces = m.ft.data();
  in.texture = TextureView{8, 8, 3, tex.data()};
  MeshRender r;
  render_mesh(cam, in, r);
  const int P = r.raster.num_pixels();
  std::vector<float> gD(P, 1.0f), zero_bary(size_t(P) * 3, 0.0f);
  std::vector<float> a(m.verts.size(), 0.0f), b(m.verts.size(), 0.0f);
  render_mesh_backward(cam, in, r, nullptr, gD.data(), nullptr, a.data());
  mesh_barycentrics_backward(cam, MeshView{m.verts.data(), m.num_verts(), m.faces.data(), m.num_faces()},
                             r.raster.tri.data(), zero_bary.data(), gD.data(), b.data());
  double total = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i], b[i]);
    total += std::fabs(a[i]);
  }
  EXPECT_GT(total, 0);
}
