// Forward of the Gaussian rasterizer: equality with a brute-force double reference (no
// tiles, every Gaussian at every pixel), the analytic EWA footprint, each hard cut on its
// own, hard cases, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"
#include "support/render_gaussian_harness.h"

using namespace haha;
using namespace haha::testref;

namespace {

// Thousands of tiny renders: one thread avoids OpenMP start/barrier costs (and stalls on a
// loaded machine). Thread invariance is tested explicitly below.
struct SingleThread : testing::Environment {
  void SetUp() override { set_num_threads(1); }
};
[[maybe_unused]] const auto* const kSingleThread = testing::AddGlobalTestEnvironment(new SingleThread);

constexpr double kInf = std::numeric_limits<double>::infinity();

// Occlusion map with finite and infinite regions: a slanted plane z = 1.6 .. 2.4 over the
// left two thirds of the image (cutting through the Gaussians' depth range), +inf elsewhere.
std::vector<double> stripe_depth(int w, int h) {
  std::vector<double> d(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) d[size_t(y) * w + x] = x < 2 * w / 3 ? 1.6 + 0.8 * double(y) / h : kInf;
  return d;
}

std::vector<double> gradient_background(int w, int h) {
  std::vector<double> bg(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) bg[(size_t(y) * w + x) * 3 + c] = 0.2 + 0.6 * double((x * (c + 1) + y) % 17) / 17;
  return bg;
}

template <class T>
void expect_matches_reference(const Scene& s, const CameraT<double>& cam, bool aa, bool with_depth, double tol) {
  const auto depth = with_depth ? stripe_depth(cam.width, cam.height) : std::vector<double>{};
  const auto bg = gradient_background(cam.width, cam.height);
  const Image ref = render(cam, s, aa, with_depth ? depth.data() : nullptr, bg.data(), nullptr);
  GaussianRasterState<T> state;
  const auto b = to_buffers<T>(s, depth, bg);
  const auto r = run_forward(b, cam, aa, state);
  EXPECT_LE(max_abs_diff(r.color, ref.color), tol);
  EXPECT_LE(max_abs_diff(r.alpha, ref.alpha), tol);
  EXPECT_LE(max_abs_diff(r.depth, ref.depth), tol * 3);  // depth values are ~2x colours
  EXPECT_LE(max_abs_diff(r.composite, ref.composite), tol);
  double covered = 0;
  for (double a : ref.alpha) covered += a > 0.01;
  EXPECT_GT(covered, 0.2 * double(ref.alpha.size())) << "scene should cover a good part of the image";
}

}  // namespace

TEST(GaussianForward, MatchesBruteForceDouble) {
  const auto cam = make_camera(70, 45, 60);  // not a multiple of the tile size
  for (bool aa : {false, true})
    for (bool depth : {false, true}) {
      SCOPED_TRACE(testing::Message() << "aa=" << aa << " depth=" << depth);
      expect_matches_reference<double>(random_scene(40, 7, cam, 0.02, 0.25), cam, aa, depth, 1e-10);
    }
}

TEST(GaussianForward, MatchesBruteForceFloat) {
  const auto cam = make_camera(70, 45, 60);
  for (bool aa : {false, true})
    for (bool depth : {false, true}) {
      SCOPED_TRACE(testing::Message() << "aa=" << aa << " depth=" << depth);
      expect_matches_reference<float>(random_scene(40, 8, cam, 0.02, 0.25), cam, aa, depth, 2e-5);
    }
}

TEST(GaussianForward, MatchesBruteForceWithShAndRotatedCamera) {
  auto cam = make_camera(50, 40, 45);
  {
    const Quat<double> q(0.9, 0.1, -0.3, 0.2);
    const double n = std::sqrt(qnorm2(q));
    cam.R = quat_to_mat(Quat<double>(q.w / n, q.x / n, q.y / n, q.z / n));
  }
  cam.t = Vec3<double>(0.1, -0.2, 0.3);
  for (int deg = 0; deg <= 3; ++deg) {
    SCOPED_TRACE(deg);
    expect_matches_reference<double>(random_scene(30, 11 + deg, cam, 0.03, 0.2, 0.3, 0.9, deg), cam, false, true,
                                     1e-10);
  }
}

TEST(GaussianForward, EarlyTerminationWithinTolerance) {
  // Many overlapping, fairly opaque Gaussians: most pixels stop early. A pixel stops before
  // the Gaussian that would take T below 1e-4 (3DGS rule), so at the stop
  // T < 1e-4 / (1 - alpha) and the stopped image differs from compositing everything by
  // at most 1e-4 / (1 - alpha_max) times the largest colour (colours here are <= 1). The
  // rasterizer equals the reference that applies the same stop rule.
  const auto cam = make_camera(48, 48, 50);
  const Scene s = random_scene(80, 3, cam, 0.15, 0.4, 0.85, 0.95);
  const double black[3] = {0, 0, 0};
  const Image stop = render(cam, s, false, nullptr, nullptr, black, true);
  const Image all = render(cam, s, false, nullptr, nullptr, black, false);
  GaussianRasterState<double> st;
  const auto r = run_forward(to_buffers<double>(s, {}, {}, black), cam, false, st);
  EXPECT_LE(max_abs_diff(r.color, stop.color), 1e-10);
  double omax = 0;
  for (double o : s.opacities) omax = std::max(omax, o);
  const double bound = 1e-4 / (1 - std::min(0.99, omax));
  EXPECT_LE(max_abs_diff(r.color, all.color), bound);
  EXPECT_LE(max_abs_diff(r.alpha, all.alpha), bound);
  EXPECT_LE(max_abs_diff(r.alpha, stop.alpha), 1e-10);
  int stopped = 0;
  for (size_t p = 0; p < all.alpha.size(); ++p) stopped += (1 - all.alpha[p]) < 1e-4;
  EXPECT_GT(stopped, 100) << "the scene must actually exercise the early stop";
  EXPECT_GT(max_abs_diff(stop.color, all.color), 0.0);
}

// Isotropic / z-rotated Gaussian on the optical axis: J's third column vanishes there,
// so cov2d = F R2 diag(s1^2, s2^2) R2^T F / z^2 + 0.3 I with F = diag(fx, fy).
TEST(GaussianForward, AnalyticFootprintOnAxis) {
  auto cam = make_camera(64, 64, 80);
  for (bool aa : {false, true}) {
    const double z = 2.0, s1 = 0.05, s2 = 0.02, th = 0.6, o = 0.7;
    Scene s;
    s.n = 1;
    s.means = {0, 0, z};
    s.quats = {std::cos(th / 2) * 2, 0, 0, std::sin(th / 2) * 2};  // unnormalised on purpose
    s.scales = {s1, s2, 0.03};
    s.opacities = {o};
    s.colors = {1, 1, 1};
    const double c = std::cos(th), sn = std::sin(th);
    const double A0 = cam.fx * cam.fx / (z * z) * (c * c * s1 * s1 + sn * sn * s2 * s2);
    const double B0 = cam.fx * cam.fy / (z * z) * (c * sn * (s1 * s1 - s2 * s2));
    const double C0 = cam.fy * cam.fy / (z * z) * (sn * sn * s1 * s1 + c * c * s2 * s2);
    const double A = A0 + 0.3, B = B0, C = C0 + 0.3, det = A * C - B * B;
    const double oe = aa ? o * std::sqrt((A0 * C0 - B0 * B0) / det) : o;
    GaussianRasterState<double> st;
    const auto r = run_forward(to_buffers<double>(s), cam, aa, st);
    int checked = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const double dx = x + 0.5 - cam.cx, dy = y + 0.5 - cam.cy;
        const double a = oe * std::exp(-0.5 * (C * dx * dx - 2 * B * dx * dy + A * dy * dy) / det);
        const double expect = a < 1.0 / 255 ? 0.0 : a;
        ASSERT_NEAR(r.alpha[size_t(y) * 64 + x], expect, 1e-12) << x << "," << y;
        checked += expect > 0;
      }
    EXPECT_GT(checked, 50);
  }
}

TEST(GaussianForward, AlphaThresholdCut) {
  // One Gaussian; opacity chosen so the alpha at pixel (40, 32) is just above / below
  // 1/255: the pixel gets exactly that alpha, or exactly nothing.
  const auto cam = make_camera(64, 64, 80);
  Scene s;
  s.n = 1;
  s.means = {0, 0, 2};
  s.quats = {1, 0, 0, 0};
  s.scales = {0.05, 0.05, 0.05};
  s.colors = {1, 0.5, 0.25};
  const double sx = std::pow(cam.fx * 0.05 / 2, 2) + 0.3, sy = std::pow(cam.fy * 0.05 / 2, 2) + 0.3;
  const double dx = 40.5 - cam.cx, dy = 32.5 - cam.cy;
  const double g = std::exp(-0.5 * (dx * dx / sx + dy * dy / sy));
  ASSERT_LT(g, 0.5);
  const size_t pix = 32 * 64 + 40;
  for (double f : {1 + 1e-6, 1 - 1e-6}) {
    s.opacities = {f / 255.0 / g};
    GaussianRasterState<double> st;
    const auto r = run_forward(to_buffers<double>(s), cam, false, st);
    if (f > 1) {
      EXPECT_NEAR(r.alpha[pix], f / 255.0, 1e-12);
      EXPECT_NEAR(r.color[3 * pix + 1], 0.5 * f / 255.0, 1e-12);
    } else {
      EXPECT_EQ(r.alpha[pix], 0.0);
      EXPECT_EQ(r.color[3 * pix], 0.0);
    }
  }
}

TEST(GaussianForward, AlphaClampAt099) {
  const auto cam = make_camera(32, 32, 40);
  Scene s;
  s.n = 1;
  s.means = {0, 0, 2};
  s.quats = {1, 0, 0, 0};
  s.scales = {0.3, 0.3, 0.3};
  s.opacities = {1.0};
  s.colors = {1, 1, 1};
  GaussianRasterState<float> st;
  const auto r = run_forward(to_buffers<float>(s), cam, false, st);
  const size_t pix = size_t(int(cam.cy)) * 32 + size_t(cam.cx);
  EXPECT_FLOAT_EQ(r.alpha[pix], 0.99f);
}

// A Gaussian's centre vs the occluder depth D: at D or in front it shows, behind it does
// not, and a deeper Gaussian after an occluded one does not show either.
TEST(GaussianForward, DepthTestAtMeshDepth) {
  const auto cam = make_camera(32, 32, 40);
  const double z = 2.0;
  Scene s;
  s.n = 1;
  s.means = {0, 0, z};
  s.quats = {1, 0, 0, 0};
  s.scales = {0.2, 0.2, 0.2};
  s.opacities = {0.8};
  s.colors = {0.2, 0.4, 0.6};
  const size_t P = 32 * 32;
  for (double Df : {z, std::nextafter(z, 10.0), z + 1e-9, std::nextafter(z, 0.0), z - 1e-9}) {
    std::vector<double> D(P, Df);
    GaussianRasterState<double> st;
    const auto r = run_forward(to_buffers<double>(s, D), cam, false, st);
    double sum = 0;
    for (double a : r.alpha) sum += a;
    if (Df >= z) {
      EXPECT_GT(sum, 1.0) << "at/in front of the mesh: visible, D - z = " << Df - z;
    } else {
      EXPECT_EQ(sum, 0.0) << "behind the mesh: hidden, D - z = " << Df - z;
    }
  }
  // float: exactly at the mesh depth (same float) contributes.
  {
    std::vector<double> D(P, z);
    GaussianRasterState<float> st;
    const auto r = run_forward(to_buffers<float>(s, D), cam, false, st);
    EXPECT_GT(r.alpha[16 * 32 + 16], 0.5f);
  }
  // Two Gaussians, D between them: only the front one shows, per pixel; with D in front of
  // both, nothing shows; half the image occluded, half not.
  Scene two = s;
  two.n = 2;
  two.means = {0, 0, 1.9, 0.01, 0, 2.1};
  two.quats = {1, 0, 0, 0, 1, 0, 0, 0};
  two.scales = {0.2, 0.2, 0.2, 0.2, 0.2, 0.2};
  two.opacities = {0.5, 0.7};
  two.colors = {1, 0, 0, 0, 1, 0};
  Scene front = two;
  front.n = 1;
  front.means.resize(3), front.quats.resize(4), front.scales.resize(3), front.opacities.resize(1),
      front.colors.resize(3);
  std::vector<double> D(P);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) D[size_t(y) * 32 + x] = x < 16 ? 2.0 : 1.5;
  GaussianRasterState<double> st;
  const auto r2 = run_forward(to_buffers<double>(two, D), cam, false, st);
  const auto r1 = run_forward(to_buffers<double>(front, {}), cam, false, st);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const size_t p = size_t(y) * 32 + x;
      if (x < 16) {
        EXPECT_DOUBLE_EQ(r2.alpha[p], r1.alpha[p]);
        EXPECT_DOUBLE_EQ(r2.color[3 * p + 1], 0.0);
      } else {
        EXPECT_EQ(r2.alpha[p], 0.0);
      }
    }
}

TEST(GaussianForward, EmptySceneShowsBackground) {
  const auto cam = make_camera(20, 17, 30);
  Scene s;
  const auto bg = gradient_background(20, 17);
  GaussianRasterState<float> st;
  const auto r = run_forward(to_buffers<float>(s, {}, bg), cam, false, st);
  EXPECT_LE(max_abs_diff(r.composite, bg), 1e-7);
  for (float v : r.color) EXPECT_EQ(v, 0.f);
  for (float v : r.alpha) EXPECT_EQ(v, 0.f);
  for (float v : r.depth) EXPECT_EQ(v, 0.f);
  EXPECT_EQ(st.pairs(), 0);
}

// Hard geometric cases, each against the brute-force reference and free of NaN/Inf.
TEST(GaussianForward, HardCases) {
  const auto cam = make_camera(48, 40, 50);
  auto one = [](double x, double y, double z, double s, double o) {
    Scene sc;
    sc.n = 1;
    sc.means = {x, y, z};
    sc.quats = {0.8, 0.2, -0.3, 0.1};
    sc.scales = {s, s * 0.7, s * 0.4};
    sc.opacities = {o};
    sc.colors = {0.9, 0.5, 0.1};
    return sc;
  };
  struct Case {
    const char* name;
    Scene s;
    bool visible, visible_aa;  // antialiased: a footprint far below a pixel fades out
  };
  const double nearz = cam.near_plane;
  std::vector<Case> cases = {
      {"behind camera", one(0, 0, -1, 0.1, 0.9), false, false},
      {"at the near plane", one(0, 0, nearz, 0.1, 0.9), false, false},
      {"just beyond the near plane", one(0.0001, 0, nearz * 1.01, 0.001, 0.9), true, true},
      {"covering the whole screen", one(0.05, -0.02, 1.0, 2.0, 0.6), true, true},
      {"sub-pixel", one(0.01, 0.02, 2.0, 1e-5, 0.9), true, false},
      {"zero scale", one(0.01, 0.02, 2.0, 0.0, 0.9), true, false},
      {"far off-screen (Jacobian clamp), huge", one(30, 0, 2.0, 20.0, 0.9), true, true},
      {"outside the view", one(50, 0, 2.0, 0.01, 0.9), false, false},
      {"transparent", one(0, 0, 2.0, 0.1, 0.5 / 255), false, false},
  };
  Scene zq = one(0, 0, 2, 0.1, 0.9);
  zq.quats = {0, 0, 0, 0};
  cases.push_back({"zero quaternion", zq, false, false});
  for (const auto& c : cases)
    for (bool aa : {false, true}) {
      SCOPED_TRACE(testing::Message() << c.name << " aa=" << aa);
      const double bgc[3] = {0.1, 0.2, 0.3};
      const Image ref = render(cam, c.s, aa, nullptr, nullptr, bgc);
      for (int prec = 0; prec < 2; ++prec) {
        double sum = 0, diff = 0;
        bool finite = true, vis = false;
        if (prec == 0) {
          GaussianRasterState<double> st;
          const auto r = run_forward(to_buffers<double>(c.s, {}, {}, bgc), cam, aa, st);
          diff = std::max(max_abs_diff(r.composite, ref.composite), max_abs_diff(r.alpha, ref.alpha));
          finite = all_finite(r.color) && all_finite(r.alpha) && all_finite(r.depth) && all_finite(r.composite);
          for (double a : r.alpha) sum += a;
          vis = st.radii[0] > 0;
        } else {
          GaussianRasterState<float> st;
          const auto r = run_forward(to_buffers<float>(c.s, {}, {}, bgc), cam, aa, st);
          diff = std::max(max_abs_diff(r.composite, ref.composite), max_abs_diff(r.alpha, ref.alpha)) * 1e-5;
          finite = all_finite(r.color) && all_finite(r.alpha) && all_finite(r.depth) && all_finite(r.composite);
          for (float a : r.alpha) sum += a;
          vis = st.radii[0] > 0;
        }
        EXPECT_TRUE(finite);
        EXPECT_LE(diff, 1e-9) << "precision " << prec;
        const bool expect_visible = aa ? c.visible_aa : c.visible;
        EXPECT_EQ(sum > 0, expect_visible);
        EXPECT_EQ(vis, expect_visible);
      }
    }
}

TEST(GaussianForward, WholeScreenCoverage) {
  const auto cam = make_camera(48, 40, 50);
  Scene s;
  s.n = 1;
  s.means = {0, 0, 1.0};
  s.quats = {1, 0, 0, 0};
  s.scales = {3, 3, 3};
  s.opacities = {0.5};
  s.colors = {1, 1, 1};
  GaussianRasterState<float> st;
  const auto r = run_forward(to_buffers<float>(s), cam, false, st);
  for (float a : r.alpha) EXPECT_GT(a, 0.45f);
  EXPECT_EQ(st.pairs(), int64_t(st.tiles_x) * st.tiles_y);
}

TEST(GaussianForward, DeterministicAcrossThreadsAndStateReuse) {
  const auto cam = make_camera(70, 45, 60);
  const Scene s = random_scene(60, 21, cam, 0.02, 0.3);
  const Scene other = random_scene(25, 22, cam, 0.05, 0.1);
  const auto depth = stripe_depth(70, 45);
  const auto b = to_buffers<float>(s, depth);
  GaussianRasterState<float> st1, st2;
  const int saved = num_threads();
  set_num_threads(1);
  const auto r1 = run_forward(b, cam, true, st1);
  set_num_threads(2);
  run_forward(to_buffers<float>(other), cam, false, st2);  // dirty the state first
  const auto r2 = run_forward(b, cam, true, st2);
  set_num_threads(saved);
  EXPECT_EQ(r1.color, r2.color);
  EXPECT_EQ(r1.alpha, r2.alpha);
  EXPECT_EQ(r1.depth, r2.depth);
  EXPECT_EQ(r1.composite, r2.composite);
}

TEST(GaussianForward, OcclusionCullingDropsHiddenPairs) {
  // A depth map in front of everything: no pair survives binning, output is empty.
  const auto cam = make_camera(64, 64, 60);
  const Scene s = random_scene(50, 5, cam, 0.02, 0.1);
  std::vector<double> D(64 * 64, 1.0);
  GaussianRasterState<float> st;
  const auto r = run_forward(to_buffers<float>(s, D), cam, false, st);
  EXPECT_EQ(st.pairs(), 0);
  for (float a : r.alpha) EXPECT_EQ(a, 0.f);
  for (int rad : st.radii) EXPECT_EQ(rad, 0) << "hidden everywhere counts as not visible";
}

TEST(GaussianForward, RejectsInconsistentInputs) {
  const auto cam = make_camera(8, 8, 10).cast<float>();
  GaussianRasterState<float> st;
  std::vector<float> m(3), q(4), s(3), o(1), c(3);
  GaussianInputs<float> in;
  in.count = 1;
  in.means = m.data();
  in.quats = q.data();
  in.scales = s.data();
  in.opacities = o.data();
  EXPECT_THROW(rasterize_gaussians(in, cam, {}, st, {}), Error);  // no colours
  in.colors = c.data();
  in.sh = c.data();
  EXPECT_THROW(rasterize_gaussians(in, cam, {}, st, {}), Error);  // both
  in.sh = nullptr;
  auto bad = cam;
  bad.width = 0;
  EXPECT_THROW(rasterize_gaussians(in, bad, {}, st, {}), Error);
  EXPECT_NO_THROW(rasterize_gaussians(in, cam, {}, st, {}));
}
