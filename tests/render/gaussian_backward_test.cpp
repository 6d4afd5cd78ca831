// Backward of the Gaussian rasterizer against central finite differences in double, for
// every input (means, quaternions, scales, opacities, colours, SH coefficients, per-pixel
// background, background colour), in plain and antialiased mode, with the occlusion map,
// the Jacobian clamp and the early stop active. Scenes are picked (first seed that
// qualifies) at a stated distance from every hard cut, so that a perturbation of
// eps = 1e-7 cannot cross one; the cuts themselves are tested on their own below.
// Tolerance: |analytic - fd| <= 1e-6 * max(|fd|, g_scale) where g_scale is the largest
// |gradient| of that input (central differences in double at eps = 1e-7 lose ~1e-9
// relative to rounding; truncation is O(eps^2)).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

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
constexpr double kEps = 1e-7;

struct Weights {
  std::vector<double> color, alpha, depth, composite;
};

Weights random_weights(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  const size_t P = size_t(w) * h;
  Weights wt;
  for (size_t i = 0; i < 3 * P; ++i) wt.color.push_back(U(rng)), wt.composite.push_back(U(rng));
  for (size_t i = 0; i < P; ++i) wt.alpha.push_back(U(rng)), wt.depth.push_back(U(rng));
  return wt;
}

double loss(const Rendered<double>& r, const Weights& w) {
  double L = 0;
  for (size_t i = 0; i < r.color.size(); ++i) L += w.color[i] * r.color[i] + w.composite[i] * r.composite[i];
  for (size_t i = 0; i < r.alpha.size(); ++i) L += w.alpha[i] * r.alpha[i] + w.depth[i] * r.depth[i];
  return L;
}

struct Problem {
  CameraT<double> cam;
  Buffers<double> b;
  bool aa = false;
  Weights w;
};

struct Analytic {
  std::vector<double> means, quats, scales, opacities, colors, sh, means2d, bg, bg_color;
};

Analytic analytic(Problem& p) {
  GaussianRasterState<double> st;
  run_forward(p.b, p.cam, p.aa, st);
  const int n = int(p.b.opacities.size());
  Analytic a;
  a.means.assign(3 * n, 0);
  a.quats.assign(4 * n, 0);
  a.scales.assign(3 * n, 0);
  a.opacities.assign(n, 0);
  a.colors.assign(3 * n, 0);
  a.sh.assign(p.b.sh.size(), 0);
  a.means2d.assign(2 * n, 0);
  a.bg.assign(p.b.bg.size(), 0);
  a.bg_color.assign(3, 0);
  GaussianGrads<double> g;
  g.means = a.means.data();
  g.quats = a.quats.data();
  g.scales = a.scales.data();
  g.opacities = a.opacities.data();
  g.colors = a.colors.data();
  g.sh = a.sh.data();
  g.means2d = a.means2d.data();
  g.background = a.bg.data();
  g.background_color = a.bg_color.data();
  GaussianRasterOutputGrads<double> d{p.w.color.data(), p.w.alpha.data(), p.w.depth.data(), p.w.composite.data()};
  rasterize_gaussians_backward(p.b.inputs(), p.cam.cast<double>(), settings_of(p.b, p.aa), st, d, g);
  return a;
}

double eval_loss(Problem& p) {
  GaussianRasterState<double> st;
  return loss(run_forward(p.b, p.cam, p.aa, st), p.w);
}

// Compares the analytic gradient of `param` (entries `idx`, all if empty) with central
// differences.
void check(const char* name, Problem& p, std::vector<double>& param, const std::vector<double>& grad,
           std::vector<size_t> idx = {}) {
  ASSERT_EQ(param.size(), grad.size()) << name;
  if (idx.empty())
    for (size_t k = 0; k < param.size(); ++k) idx.push_back(k);
  double gscale = 0;
  for (double g : grad) gscale = std::max(gscale, std::abs(g));
  double worst = 0;
  int nonzero = 0;
  for (size_t k : idx) {
    const double v = param[k];
    param[k] = v + kEps;
    const double lp = eval_loss(p);
    param[k] = v - kEps;
    const double lm = eval_loss(p);
    param[k] = v;
    const double fd = (lp - lm) / (2 * kEps);
    const double err = std::abs(grad[k] - fd) / std::max({std::abs(fd), gscale, 1e-12});
    worst = std::max(worst, err);
    nonzero += std::abs(fd) > 1e-6 * gscale;
    EXPECT_LE(err, 1e-6) << name << "[" << k << "] analytic " << grad[k] << " fd " << fd;
  }
  EXPECT_GT(nonzero, int(idx.size()) / 4) << name << ": most checked entries should have a gradient";
  EXPECT_GT(gscale, 0.0) << name;
}

// Margins a scene must keep from the hard cuts for eps = 1e-7 to be safe.
bool away_from_cuts(const Problem& p) {
  Margins m;
  Scene s;
  s.n = int(p.b.opacities.size());
  s.means = p.b.means, s.quats = p.b.quats, s.scales = p.b.scales, s.opacities = p.b.opacities;
  s.colors = p.b.colors, s.sh = p.b.sh, s.use_sh = !p.b.sh.empty(), s.sh_degree = p.b.sh_degree;
  render(p.cam, s, p.aa, p.b.depth_map.empty() ? nullptr : p.b.depth_map.data(),
         p.b.bg.empty() ? nullptr : p.b.bg.data(), p.b.bg_color, true, &m);
  return m.alpha_min > 2e-6 && m.alpha_max > 2e-6 && m.trans > 1e-4 && m.depth > 1e-5 && m.jac > 1e-5 &&
         m.sh_clamp > 1e-5 && m.near > 0.1 && m.zsep > 1e-5;
}

std::vector<double> stripe_depth(int w, int h) {
  std::vector<double> d(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) d[size_t(y) * w + x] = x < w / 2 ? 1.7 + 0.6 * double(y) / h : kInf;
  return d;
}

std::vector<double> some_background(int w, int h) {
  std::vector<double> bg(size_t(w) * h * 3);
  for (size_t i = 0; i < bg.size(); ++i) bg[i] = 0.1 + 0.8 * double((i * 7919) % 101) / 101;
  return bg;
}

// First seed whose scene keeps away from the cuts.
Problem make_problem(const std::function<Scene(unsigned)>& scene, const CameraT<double>& cam, bool aa, bool depth,
                     bool per_pixel_bg) {
  for (unsigned seed = 1; seed < 200; ++seed) {
    Problem p;
    p.cam = cam;
    p.aa = aa;
    const double bgc[3] = {0.3, 0.6, 0.9};
    p.b = to_buffers<double>(scene(seed), depth ? stripe_depth(cam.width, cam.height) : std::vector<double>{},
                             per_pixel_bg ? some_background(cam.width, cam.height) : std::vector<double>{}, bgc);
    p.w = random_weights(cam.width, cam.height, seed + 1000);
    if (away_from_cuts(p)) return p;
  }
  ADD_FAILURE() << "no scene away from the hard cuts";
  return {};
}

std::vector<size_t> sample_indices(size_t n, size_t k, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<size_t> idx;
  for (size_t i = 0; i < k; ++i) idx.push_back(rng() % n);
  return idx;
}

void check_all(Problem& p) {
  const Analytic a = analytic(p);
  check("means", p, p.b.means, a.means);
  check("quats", p, p.b.quats, a.quats);
  check("scales", p, p.b.scales, a.scales);
  check("opacities", p, p.b.opacities, a.opacities);
  if (p.b.sh.empty()) {
    check("colors", p, p.b.colors, a.colors);
  } else {
    check("sh", p, p.b.sh, a.sh);
  }
  if (!p.b.bg.empty()) {
    check("background", p, p.b.bg, a.bg, sample_indices(p.b.bg.size(), 200, 5));
  }
}

}  // namespace

TEST(GaussianBackward, FiniteDifferencesPlainWithDepthMapAndBackground) {
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(10, s, cam, 0.04, 0.15); }, cam, false, true, true);
  check_all(p);
}

TEST(GaussianBackward, FiniteDifferencesAntialiased) {
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(10, s, cam, 0.01, 0.15); }, cam, true, true, true);
  check_all(p);
}

TEST(GaussianBackward, FiniteDifferencesSphericalHarmonicsRotatedCamera) {
  auto cam = make_camera(36, 30, 32);
  const Quat<double> q(0.95, -0.1, 0.2, 0.15);
  const double n = std::sqrt(qnorm2(q));
  cam.R = quat_to_mat(Quat<double>(q.w / n, q.x / n, q.y / n, q.z / n));
  cam.t = Vec3<double>(0.2, 0.1, -0.3);
  for (int deg : {1, 3}) {
    SCOPED_TRACE(deg);
    auto p = make_problem([&](unsigned s) { return random_scene(8, s, cam, 0.04, 0.15, 0.3, 0.9, deg); }, cam,
                          false, true, false);
    check_all(p);
  }
}

TEST(GaussianBackward, FiniteDifferencesBackgroundColor) {
  const auto cam = make_camera(24, 20, 24);
  auto p = make_problem([&](unsigned s) { return random_scene(6, s, cam, 0.05, 0.2); }, cam, false, false, false);
  const Analytic a = analytic(p);
  std::vector<double> bgc(p.b.bg_color, p.b.bg_color + 3);
  double fd[3];
  for (int c = 0; c < 3; ++c) {
    const double v = p.b.bg_color[c];
    p.b.bg_color[c] = v + kEps;
    const double lp = eval_loss(p);
    p.b.bg_color[c] = v - kEps;
    const double lm = eval_loss(p);
    p.b.bg_color[c] = v;
    fd[c] = (lp - lm) / (2 * kEps);
    EXPECT_NEAR(a.bg_color[c], fd[c], 1e-6 * std::max(1.0, std::abs(fd[c])));
  }
}

TEST(GaussianBackward, FiniteDifferencesWithJacobianClamp) {
  // Large Gaussians whose centres lie beyond the clamp bounds (off-screen) while their
  // footprints reach into the image.
  const auto cam = make_camera(32, 32, 30);
  auto scene = [&](unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    Scene s;
    s.n = 4;
    for (int i = 0; i < 4; ++i) {
      const double z = 1.5 + U(rng);
      const double side = i % 2 ? 1 : -1;
      s.means.insert(s.means.end(), {side * z * (0.9 + 0.3 * U(rng)), (U(rng) - 0.5) * z * 0.5, z});
      s.quats.insert(s.quats.end(), {U(rng), U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5});
      s.scales.insert(s.scales.end(), {0.4 + 0.3 * U(rng), 0.3 + 0.3 * U(rng), 0.2 + 0.2 * U(rng)});
      s.opacities.push_back(0.4 + 0.5 * U(rng));
      s.colors.insert(s.colors.end(), {U(rng), U(rng), U(rng)});
    }
    return s;
  };
  auto p = make_problem(scene, cam, false, false, true);
  // The scene must really sit in the clamped regime.
  for (int i = 0; i < 4; ++i) {
    const double u = p.b.means[3 * i] / p.b.means[3 * i + 2];
    EXPECT_TRUE(u > 1.3 * (32 - cam.cx) / cam.fx || u < -1.3 * cam.cx / cam.fx);
  }
  check_all(p);
}

TEST(GaussianBackward, FiniteDifferencesWithEarlyStopActive) {
  const auto cam = make_camera(24, 24, 30);
  auto p = make_problem([&](unsigned s) { return random_scene(24, s, cam, 0.15, 0.3, 0.85, 0.97); }, cam, false,
                        false, false);
  // The early stop must be active at some pixels.
  GaussianRasterState<double> st;
  run_forward(p.b, p.cam, false, st);
  Scene s;
  s.n = int(p.b.opacities.size());
  s.means = p.b.means, s.quats = p.b.quats, s.scales = p.b.scales, s.opacities = p.b.opacities, s.colors = p.b.colors;
  const Image all = render(cam, s, false, nullptr, nullptr, p.b.bg_color, false);
  int stopped = 0;
  for (double a : all.alpha) stopped += 1 - a < 1e-4;
  ASSERT_GT(stopped, 20);
  check_all(p);
}

TEST(GaussianBackward, MeansTwoDEqualsPrincipalPointDerivative) {
  // mean2d = (fx x/z + cx, ...) and nothing else depends on cx away from the clamp, so
  // sum_i dL/dmean2d_i.x = dL/dcx.
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(10, s, cam, 0.04, 0.15); }, cam, false, true, true);
  const Analytic a = analytic(p);
  for (int axis = 0; axis < 2; ++axis) {
    double sum = 0;
    for (size_t i = 0; i < a.means2d.size() / 2; ++i) sum += a.means2d[2 * i + axis];
    double& c = axis == 0 ? p.cam.cx : p.cam.cy;
    const double v = c;
    c = v + kEps;
    const double lp = eval_loss(p);
    c = v - kEps;
    const double lm = eval_loss(p);
    c = v;
    const double fd = (lp - lm) / (2 * kEps);
    EXPECT_NEAR(sum, fd, 1e-6 * std::max(1.0, std::abs(fd)));
    EXPECT_GT(std::abs(fd), 1e-3);
  }
}

TEST(GaussianBackward, MeansTwoDNormAccumulates) {
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(10, s, cam, 0.04, 0.15); }, cam, false, true, true);
  GaussianRasterState<double> st;
  run_forward(p.b, p.cam, false, st);
  const int n = int(p.b.opacities.size());
  std::vector<double> m2(2 * n), acc(n, 0.5);
  GaussianGrads<double> g;
  g.means2d = m2.data();
  g.means2d_norm_accum = acc.data();
  GaussianRasterOutputGrads<double> d{p.w.color.data(), p.w.alpha.data(), p.w.depth.data(), p.w.composite.data()};
  for (int rep = 0; rep < 2; ++rep) rasterize_gaussians_backward(p.b.inputs(), p.cam, settings_of(p.b, false), st, d, g);
  int visible = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(acc[size_t(i)], 0.5 + 2 * std::hypot(m2[2 * i], m2[2 * i + 1]), 1e-12);
    visible += st.visible(i);
  }
  EXPECT_GT(visible, n / 2);
}

TEST(GaussianBackward, MeansTwoDNormScalesEachAxisByItsOwnFactor) {
  // NDC units on a non-square image: x by W/2, y by H/2 (not one factor for both).
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(10, s, cam, 0.04, 0.15); }, cam, false, true, true);
  GaussianRasterState<double> st;
  run_forward(p.b, p.cam, false, st);
  const int n = int(p.b.opacities.size());
  std::vector<double> m2(2 * n), acc(n, 0.0);
  GaussianGrads<double> g;
  g.means2d = m2.data();
  g.means2d_norm_accum = acc.data();
  g.means2d_norm_scale_x = 0.5 * p.cam.width;
  g.means2d_norm_scale_y = 0.5 * p.cam.height;
  GaussianRasterOutputGrads<double> d{p.w.color.data(), p.w.alpha.data(), p.w.depth.data(), p.w.composite.data()};
  rasterize_gaussians_backward(p.b.inputs(), p.cam, settings_of(p.b, false), st, d, g);
  int anisotropic = 0;
  for (int i = 0; i < n; ++i) {
    const double x = 20.0 * m2[2 * i], y = 16.0 * m2[2 * i + 1];
    EXPECT_NEAR(acc[size_t(i)], std::hypot(x, y), 1e-12 * (1 + std::hypot(x, y)));
    anisotropic += std::fabs(std::hypot(x, y) - 20.0 * std::hypot(m2[2 * i], m2[2 * i + 1])) > 1e-6;
  }
  EXPECT_GT(anisotropic, n / 2);  // one factor for both axes would differ for these
}

TEST(GaussianBackward, FloatMatchesDouble) {
  // The float instantiation (radix-sorted bins) gives the double gradients up to float
  // rounding: max error <= 1e-4 of the largest gradient of each input (seen: ~1e-6).
  const auto cam = make_camera(40, 32, 36);
  auto p = make_problem([&](unsigned s) { return random_scene(12, s, cam, 0.04, 0.15); }, cam, true, true, true);
  const Analytic ad = analytic(p);
  Buffers<float> b;
  b.means = cast_vec<float>(p.b.means), b.quats = cast_vec<float>(p.b.quats), b.scales = cast_vec<float>(p.b.scales);
  b.opacities = cast_vec<float>(p.b.opacities), b.colors = cast_vec<float>(p.b.colors);
  b.depth_map = cast_vec<float>(p.b.depth_map), b.bg = cast_vec<float>(p.b.bg);
  GaussianRasterState<float> st;
  run_forward(b, cam, true, st);
  const int n = int(b.opacities.size());
  std::vector<float> dm(3 * n), dq(4 * n), ds(3 * n), dop(n), dc(3 * n), dbg(b.bg.size());
  GaussianGrads<float> g;
  g.means = dm.data(), g.quats = dq.data(), g.scales = ds.data(), g.opacities = dop.data(), g.colors = dc.data();
  g.background = dbg.data();
  const auto wc = cast_vec<float>(p.w.color), wa = cast_vec<float>(p.w.alpha), wd = cast_vec<float>(p.w.depth),
             wm = cast_vec<float>(p.w.composite);
  rasterize_gaussians_backward(b.inputs(), cam.cast<float>(), settings_of(b, true), st,
                               GaussianRasterOutputGrads<float>{wc.data(), wa.data(), wd.data(), wm.data()}, g);
  auto rel = [](const std::vector<float>& f, const std::vector<double>& d) {
    double m = 0;
    for (double v : d) m = std::max(m, std::abs(v));
    return max_abs_diff(f, d) / m;
  };
  EXPECT_LE(rel(dm, ad.means), 1e-4);
  EXPECT_LE(rel(dq, ad.quats), 1e-4);
  EXPECT_LE(rel(ds, ad.scales), 1e-4);
  EXPECT_LE(rel(dop, ad.opacities), 1e-4);
  EXPECT_LE(rel(dc, ad.colors), 1e-4);
  EXPECT_LE(rel(dbg, ad.bg), 1e-4);
}

// --- the cuts on their own ---------------------------------------------------------------

namespace {
Scene single(double z, double s, double o) {
  Scene sc;
  sc.n = 1;
  sc.means = {0.01, -0.02, z};
  sc.quats = {0.9, 0.1, 0.2, -0.1};
  sc.scales = {s, s * 0.8, s * 0.5};
  sc.opacities = {o};
  sc.colors = {0.8, 0.4, 0.2};
  return sc;
}
Scene concat(Scene a, const Scene& b) {
  a.n += b.n;
  a.means.insert(a.means.end(), b.means.begin(), b.means.end());
  a.quats.insert(a.quats.end(), b.quats.begin(), b.quats.end());
  a.scales.insert(a.scales.end(), b.scales.begin(), b.scales.end());
  a.opacities.insert(a.opacities.end(), b.opacities.begin(), b.opacities.end());
  a.colors.insert(a.colors.end(), b.colors.begin(), b.colors.end());
  return a;
}
}  // namespace

TEST(GaussianBackward, OccludedGaussianGetsNoGradient) {
  // Two Gaussians; the occluder sits between them everywhere: the back one has zero
  // gradient and the front one's gradient equals that of the front one alone.
  const auto cam = make_camera(32, 32, 40);
  const Scene two = concat(single(1.8, 0.15, 0.6), single(2.2, 0.15, 0.8));
  const std::vector<double> D(32 * 32, 2.0);
  Problem p2, p1;
  p2.cam = p1.cam = cam;
  p2.w = p1.w = random_weights(32, 32, 3);
  const double bgc[3] = {0.5, 0.5, 0.5};
  p2.b = to_buffers<double>(two, D, {}, bgc);
  p1.b = to_buffers<double>(single(1.8, 0.15, 0.6), D, {}, bgc);
  const Analytic a2 = analytic(p2), a1 = analytic(p1);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(a2.means[3 + k], 0.0);
    EXPECT_EQ(a2.scales[3 + k], 0.0);
    EXPECT_EQ(a2.colors[3 + k], 0.0);
    EXPECT_DOUBLE_EQ(a2.means[k], a1.means[k]);
  }
  EXPECT_EQ(a2.opacities[1], 0.0);
  EXPECT_DOUBLE_EQ(a2.opacities[0], a1.opacities[0]);
  EXPECT_NE(a1.means[0], 0.0);
}

TEST(GaussianBackward, GradientOnlyFromPixelsAboveAlphaThreshold) {
  // Loss on one pixel where the Gaussian's alpha is just below 1/255: zero gradient; just
  // above: the gradient of alpha there (checked by finite differences of the same pixel).
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
  const size_t pix = 32 * 64 + 40;
  for (double f : {1 - 1e-4, 1 + 1e-4}) {
    s.opacities = {f / 255.0 / g};
    Problem p;
    p.cam = cam;
    p.b = to_buffers<double>(s);
    p.w = random_weights(64, 64, 1);
    for (auto* v : {&p.w.color, &p.w.composite, &p.w.depth}) std::fill(v->begin(), v->end(), 0.0);
    std::fill(p.w.alpha.begin(), p.w.alpha.end(), 0.0);
    p.w.alpha[pix] = 1;
    const Analytic a = analytic(p);
    if (f < 1) {
      for (double v : a.means) EXPECT_EQ(v, 0.0);
      EXPECT_EQ(a.opacities[0], 0.0);
    } else {
      EXPECT_NEAR(a.opacities[0], g, 1e-12);  // alpha = o G at that pixel
      check("means", p, p.b.means, a.means, {0, 1});
    }
  }
}

TEST(GaussianBackward, ClampedAlphaPassesNoGradientToOpacity) {
  const auto cam = make_camera(16, 16, 20);
  Scene s = single(2.0, 0.5, 1.0);
  Problem p;
  p.cam = cam;
  p.b = to_buffers<double>(s);
  p.w = random_weights(16, 16, 2);
  for (auto* v : {&p.w.color, &p.w.composite, &p.w.depth}) std::fill(v->begin(), v->end(), 0.0);
  std::fill(p.w.alpha.begin(), p.w.alpha.end(), 0.0);
  const size_t centre = size_t(int(cam.cy)) * 16 + size_t(cam.cx);
  p.w.alpha[centre] = 1;
  GaussianRasterState<double> st;
  const auto r = run_forward(p.b, cam, false, st);
  ASSERT_DOUBLE_EQ(r.alpha[centre], 0.99);
  const Analytic a = analytic(p);
  EXPECT_EQ(a.opacities[0], 0.0);
  for (double v : a.means) EXPECT_EQ(v, 0.0);
}

TEST(GaussianBackward, GaussiansAfterTheEarlyStopGetNoGradient) {
  // Four equal, nearly opaque Gaussians stacked in depth on the axis: at the centre the
  // fourth would take T below 1e-4 and is not composited there; with the loss on that one
  // pixel it gets no gradient, the first three do.
  const auto cam = make_camera(16, 16, 20);
  Scene s;
  s.n = 4;
  for (int i = 0; i < 4; ++i) {
    s.means.insert(s.means.end(), {0, 0, 2.0 + 0.1 * i});
    s.quats.insert(s.quats.end(), {1, 0, 0, 0});
    s.scales.insert(s.scales.end(), {0.3, 0.3, 0.3});
    s.opacities.push_back(0.96);
    s.colors.insert(s.colors.end(), {0.2 * i, 0.5, 1 - 0.2 * i});
  }
  Problem p;
  p.cam = cam;
  p.b = to_buffers<double>(s);
  p.w = random_weights(16, 16, 4);
  for (auto* v : {&p.w.color, &p.w.composite, &p.w.depth, &p.w.alpha}) std::fill(v->begin(), v->end(), 0.0);
  const size_t centre = size_t(int(cam.cy)) * 16 + size_t(cam.cx);
  for (int c = 0; c < 3; ++c) p.w.color[3 * centre + c] = 1.0 + c;
  p.w.alpha[centre] = 1;
  const Analytic a = analytic(p);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(a.colors[9 + k], 0.0);
  EXPECT_EQ(a.opacities[3], 0.0);
  for (int i = 0; i < 3; ++i) EXPECT_NE(a.opacities[i], 0.0);
  check("opacities", p, p.b.opacities, a.opacities, {0, 1, 2});
}

// --- hard cases -----------------------------------------------------------------------

TEST(GaussianBackward, HardCasesGiveFiniteGradients) {
  const auto cam = make_camera(32, 24, 30);
  std::vector<Scene> cases = {single(-1, 0.1, 0.9),  single(cam.near_plane * 1.01, 0.001, 0.9),
                              single(1.0, 2.0, 0.6), single(2.0, 1e-5, 0.9),
                              single(2.0, 0.0, 0.9), single(cam.near_plane, 0.1, 0.9)};
  Scene empty;
  cases.push_back(empty);
  for (size_t c = 0; c < cases.size(); ++c)
    for (bool aa : {false, true}) {
      SCOPED_TRACE(testing::Message() << "case " << c << " aa=" << aa);
      Problem p;
      p.cam = cam;
      p.aa = aa;
      p.b = to_buffers<double>(cases[c], {}, some_background(32, 24));
      p.w = random_weights(32, 24, 9);
      const Analytic a = analytic(p);
      for (const auto* v : {&a.means, &a.quats, &a.scales, &a.opacities, &a.colors, &a.means2d, &a.bg})
        EXPECT_TRUE(all_finite(*v));
      if (c == 0 || c == 5) {  // behind the camera / on the near plane: culled
        for (double v : a.means) EXPECT_EQ(v, 0.0);
      }
    }
}

TEST(GaussianBackward, DeterministicAcrossThreads) {
  const auto cam = make_camera(70, 45, 60);
  const Scene s = random_scene(60, 31, cam, 0.02, 0.3);
  auto run = [&](int threads) {
    set_num_threads(threads);
    auto b = to_buffers<float>(s, stripe_depth(70, 45), some_background(70, 45));
    GaussianRasterState<float> st;
    run_forward(b, cam, false, st);
    const auto wd = random_weights(70, 45, 5);
    std::vector<float> wc(wd.color.begin(), wd.color.end()), wa(wd.alpha.begin(), wd.alpha.end());
    std::vector<float> dm(3 * 60), dq(4 * 60), dbg(b.bg.size());
    GaussianGrads<float> g;
    g.means = dm.data();
    g.quats = dq.data();
    g.background = dbg.data();
    GaussianRasterOutputGrads<float> d{wc.data(), wa.data(), nullptr, wc.data()};
    rasterize_gaussians_backward(b.inputs(), cam.cast<float>(), settings_of(b, false), st, d, g);
    dm.insert(dm.end(), dq.begin(), dq.end());
    dm.insert(dm.end(), dbg.begin(), dbg.end());
    return dm;
  };
  const int saved = num_threads();
  const auto a = run(1), b = run(2);
  set_num_threads(saved);
  EXPECT_EQ(a, b);
}
