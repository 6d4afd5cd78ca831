// Texture sampling: conventions (row 0 = v = 1, texel centres), clamp to edge, finite-
// difference gradients in double w.r.t. texels and UVs, UV seams through per-corner UVs.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "render/render_mesh.h"
#include "render/texture.h"

using namespace haha;

namespace {

struct Tex {
  int w, h, c;
  std::vector<double> data;
  TextureViewT<double> view() const { return {w, h, c, data.data()}; }
};

Tex random_texture(int w, int h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  Tex t{w, h, c, std::vector<double>(size_t(w) * h * c)};
  for (double& v : t.data) v = U(rng);
  return t;
}

// UVs whose texel coordinates have fractional parts in [0.15, 0.85]: away from the
// bilinear kinks at texel-centre lines and inside the clamp range.
std::vector<double> interior_uvs(int n, int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> X(0, w - 2), Y(0, h - 2);
  std::uniform_real_distribution<double> F(0.15, 0.85);
  std::vector<double> uv(2 * size_t(n));
  for (int i = 0; i < n; ++i) {
    const double x = X(rng) + F(rng), y = Y(rng) + F(rng);
    uv[2 * i] = (x + 0.5) / w;
    uv[2 * i + 1] = 1 - (y + 0.5) / h;
  }
  return uv;
}

}  // namespace

TEST(Texture, TexelCentresAndOrientation) {
  const Tex t = random_texture(5, 4, 3, 1);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) {
      double out[3];
      bilinear_sample(t.view(), (i + 0.5) / 5, 1 - (j + 0.5) / 4, out);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(out[c], t.data[(j * 5 + i) * 3 + c], 1e-14) << i << "," << j;
    }
  // v = 1 is row 0 (top), u = 0 is column 0.
  double top_left[3];
  bilinear_sample(t.view(), 0.0, 1.0, top_left);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(top_left[c], t.data[c]);
  double bottom_right[3];
  bilinear_sample(t.view(), 1.0, 0.0, bottom_right);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(bottom_right[c], t.data[(3 * 5 + 4) * 3 + c]);
}

TEST(Texture, LinearTextureReproducedExactly) {
  // value(x, y) = 0.3 x - 0.7 y + 2 at texel centres: bilinear sampling reproduces the linear
  // function everywhere between the outer texel centres.
  Tex t{9, 6, 1, {}};
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 9; ++i) t.data.push_back(0.3 * i - 0.7 * j + 2);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> X(0, 8), Y(0, 5);
  for (int k = 0; k < 200; ++k) {
    const double x = X(rng), y = Y(rng);
    double out;
    bilinear_sample(t.view(), (x + 0.5) / 9, 1 - (y + 0.5) / 6, &out);
    EXPECT_NEAR(out, 0.3 * x - 0.7 * y + 2, 1e-12);
  }
}

TEST(Texture, ClampToEdgeAndNaN) {
  const Tex t = random_texture(4, 3, 2, 3);
  // Outside [0, 1] and beyond the outer texel centres: the border texel holds, zero UV grad.
  const double uvs[][2] = {{-0.5, 0.5}, {1.7, 0.5}, {0.5, -3.0}, {0.5, 2.0}, {-1, -1}, {0.05, 0.5}};
  for (auto& q : uvs) {
    double out[2], out2[2];
    bilinear_sample(t.view(), q[0], q[1], out);
    const double uc = std::clamp(q[0], 0.5 / 4, 3.5 / 4), vc = std::clamp(q[1], 0.5 / 3, 2.5 / 3);
    bilinear_sample(t.view(), uc, vc, out2);
    for (int c = 0; c < 2; ++c) EXPECT_NEAR(out[c], out2[c], 1e-14);
    const double g[2] = {1.0, -2.0};
    double gu = 7, gv = 7;
    bilinear_sample_backward(t.view(), q[0], q[1], g, (double*)nullptr, &gu, &gv);
    if (q[0] < 0.5 / 4 || q[0] > 3.5 / 4) {
      EXPECT_EQ(gu, 0.0);
    }
    if (q[1] < 0.5 / 3 || q[1] > 2.5 / 3) {
      EXPECT_EQ(gv, 0.0);
    }
  }
  double out[2];
  bilinear_sample(t.view(), double(NAN), double(NAN), out);
  EXPECT_TRUE(std::isfinite(out[0]) && std::isfinite(out[1]));
  // 1 x 1 texture: constant.
  const Tex one = random_texture(1, 1, 2, 4);
  bilinear_sample(one.view(), 0.3, 0.9, out);
  EXPECT_EQ(out[0], one.data[0]);
  EXPECT_EQ(out[1], one.data[1]);
}

TEST(Texture, GradientWrtTexelsAndUvMatchesFiniteDifferences) {
  const int W = 7, H = 5, C = 3, P = 60;
  Tex t = random_texture(W, H, C, 5);
  std::vector<double> uv = interior_uvs(P, W, H, 6);
  std::vector<int32_t> tri(P, 0);
  for (int p = 0; p < P; p += 9) tri[p] = -1;  // uncovered pixels: no value, no gradient
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> g(size_t(P) * C);
  for (double& v : g) v = U(rng);
  auto loss = [&](const Tex& tt, const std::vector<double>& q) {
    std::vector<double> out(size_t(P) * C);
    sample_texture(tt.view(), P, tri.data(), q.data(), out.data());
    double L = 0;
    for (size_t i = 0; i < out.size(); ++i) L += g[i] * out[i];
    return L;
  };
  std::vector<double> gt(t.data.size(), 0.0), guv(uv.size(), 9.0);
  sample_texture_backward(t.view(), P, tri.data(), uv.data(), g.data(), gt.data(), guv.data());
  const double h = 1e-6;
  // Relative tolerance 1e-7 of (|analytic| + 1): the loss is linear in texels, and
  // piecewise bilinear in UV with no kink within h of the sample points.
  for (size_t i = 0; i < t.data.size(); ++i) {
    Tex tp = t, tm = t;
    tp.data[i] += h;
    tm.data[i] -= h;
    EXPECT_NEAR((loss(tp, uv) - loss(tm, uv)) / (2 * h), gt[i], 1e-7 * (std::fabs(gt[i]) + 1)) << "texel " << i;
  }
  const double hu = 1e-8;
  for (size_t i = 0; i < uv.size(); ++i) {
    auto up = uv, um = uv;
    up[i] += hu;
    um[i] -= hu;
    const double fd = (loss(t, up) - loss(t, um)) / (2 * hu);
    EXPECT_NEAR(fd, guv[i], 1e-6 * (std::fabs(guv[i]) + 1)) << "uv " << i;
    if (tri[i / 2] < 0) {
      EXPECT_EQ(guv[i], 0.0);
    }
  }
}

TEST(Texture, BackwardAccumulatesAndIsThreadIndependent) {
  const int W = 16, H = 16, C = 3, P = 5000;
  const Tex td = random_texture(W, H, C, 8);
  const std::vector<float> tex(td.data.begin(), td.data.end());
  const TextureView view{W, H, C, tex.data()};
  const std::vector<double> uvd = interior_uvs(P, W, H, 9);
  const std::vector<float> uv(uvd.begin(), uvd.end());
  std::vector<float> g(size_t(P) * C, 0.25f);
  std::vector<float> g1(tex.size(), 1.0f), g2(tex.size(), 1.0f);
  const int saved = num_threads();
  set_num_threads(1);
  sample_texture_backward(view, P, nullptr, uv.data(), g.data(), g1.data(), nullptr);
  set_num_threads(2);
  sample_texture_backward(view, P, nullptr, uv.data(), g.data(), g2.data(), nullptr);
  set_num_threads(saved);
  double total = 0;
  for (size_t i = 0; i < g1.size(); ++i) {
    EXPECT_NEAR(g1[i], g2[i], 1e-4f * std::fabs(g1[i]));
    total += g1[i] - 1.0;  // accumulated on top of the initial 1
  }
  // Bilinear weights sum to 1 per sample: the texel gradient sums to sum(grad_out).
  EXPECT_NEAR(total, 0.25 * P * C, 1e-3 * P);
}

TEST(Texture, EmptyTextureThrows) {
  float uv[2] = {0.5f, 0.5f}, out[3];
  EXPECT_THROW(sample_texture(TextureView{0, 4, 3, nullptr}, 1, nullptr, uv, out), Error);
  EXPECT_THROW(sample_texture_backward(TextureView{4, 4, 0, out}, 1, nullptr, uv, out, out, out), Error);
}

namespace {

// A quad in the plane z = 0 (world), split along its diagonal p00-p11 into two triangles
// whose UV charts lie in different halves of the texture: the diagonal is a UV seam.
struct SeamScene {
  std::vector<float> verts = {-0.5f, -0.5f, 0, 0.5f, -0.5f, 0, 0.5f, 0.5f, 0, -0.5f, 0.5f, 0};
  std::vector<int32_t> faces = {0, 1, 2, 0, 2, 3};
  std::vector<float> uv;
  std::vector<int32_t> ft = {0, 1, 2, 3, 4, 5};
  Camera cam;
  SeamScene() {
    // Chart of triangle 0 in u in [0.05, 0.45], of triangle 1 in u in [0.55, 0.95].
    const int corner[6] = {0, 1, 2, 0, 2, 3};
    for (int k = 0; k < 6; ++k) {
      const float x = verts[3 * corner[k]], y = verts[3 * corner[k] + 1];
      uv.push_back((k < 3 ? 0.05f : 0.55f) + 0.4f * (x + 0.5f));
      uv.push_back(0.05f + 0.9f * (y + 0.5f));
    }
    cam.width = cam.height = 48;
    cam.fx = cam.fy = 60;
    cam.cx = cam.cy = 24;
    cam.t = Vec3f(0.01f, -0.02f, 1.5f);  // quad centred in view, 1.5 m away
  }
  MeshRenderInput input(const TextureView& tex) const {
    MeshRenderInput in;
    in.verts = verts.data();
    in.num_verts = 4;
    in.faces = faces.data();
    in.num_faces = 2;
    in.uv = uv.data();
    in.num_uv = 6;
    in.uv_faces = ft.data();
    in.texture = tex;
    return in;
  }
};

}  // namespace

TEST(Texture, UvSeamSamplesEachSideFromItsOwnChart) {
  // Left half red, right half blue, a green column band between the charts: each triangle
  // must show only its chart's colour, also at the pixels along the seam (no blending across).
  const int W = 64, H = 32;
  std::vector<float> tex(size_t(W) * H * 3, 0.0f);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      float* t = &tex[(size_t(j) * W + i) * 3];
      if (i < 30) t[0] = 1;
      else if (i < 34) t[1] = 1;
      else t[2] = 1;
    }
  SeamScene s;
  MeshRender r;
  render_mesh(s.cam, s.input(TextureView{W, H, 3, tex.data()}), r);
  int n[2] = {0, 0};
  for (int p = 0; p < r.raster.num_pixels(); ++p) {
    const int f = r.raster.tri[p];
    const float* c = &r.color[3 * p];
    if (f < 0) {
      EXPECT_EQ(c[0] + c[1] + c[2], 0.0f);
      continue;
    }
    ++n[f];
    // Exactly no green and none of the other chart's colour; the own colour up to the
    // rounding of the bilinear weights' sum.
    EXPECT_NEAR(c[0], f == 0 ? 1.0f : 0.0f, f == 0 ? 1e-6f : 0.0f) << p;
    EXPECT_EQ(c[1], 0.0f) << p;
    EXPECT_NEAR(c[2], f == 1 ? 1.0f : 0.0f, f == 1 ? 1e-6f : 0.0f) << p;
  }
  EXPECT_GT(n[0], 300);
  EXPECT_GT(n[1], 300);
}

TEST(Texture, UvSeamIsContinuousInTheImage) {
  // Both charts encode the same linear function of the 3D position, colour = (x, y, x + y)
  // (+ 1): the rendered colour must equal that function of the visible 3D point on both
  // sides of the seam.
  const int W = 128, H = 64;
  std::vector<float> tex(size_t(W) * H * 3);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double u = (i + 0.5) / W, v = 1 - (j + 0.5) / H;
      const double x = (u < 0.5 ? u - 0.05 : u - 0.55) / 0.4 - 0.5, y = (v - 0.05) / 0.9 - 0.5;
      float* t = &tex[(size_t(j) * W + i) * 3];
      t[0] = float(1 + x);
      t[1] = float(1 + y);
      t[2] = float(1 + x + y);
    }
  SeamScene s;
  MeshRender r;
  render_mesh(s.cam, s.input(TextureView{W, H, 3, tex.data()}), r);
  const CameraT<double> c = s.cam.cast<double>();
  int n = 0, seam_pairs = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x) {
      const int p = y * 48 + x;
      if (r.raster.tri[p] < 0) continue;
      ++n;
      const Vec3d hit = double(r.raster.depth[p]) * pixel_ray(c, x, y) - c.t;  // R = I
      const float* col = &r.color[3 * p];
      EXPECT_NEAR(col[0], 1 + hit.x, 2e-5) << x << "," << y;
      EXPECT_NEAR(col[1], 1 + hit.y, 2e-5) << x << "," << y;
      EXPECT_NEAR(col[2], 1 + hit.x + hit.y, 4e-5) << x << "," << y;
      // Horizontal neighbours across the seam differ by about one pixel's worth of colour.
      if (x + 1 < 48 && r.raster.tri[p + 1] >= 0 && r.raster.tri[p + 1] != r.raster.tri[p]) {
        ++seam_pairs;
        EXPECT_LT(std::fabs(r.color[3 * (p + 1)] - col[0]), 2.0 * 1.5 / 60);
      }
    }
  EXPECT_GT(n, 1000);
  EXPECT_GT(seam_pairs, 20);
}
