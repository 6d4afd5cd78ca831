// Losses and regularisers: central finite-difference gradient checks in double for every
// term, and the properties each must have (zero at equality, masks, known values).
//
// Gradient tolerance: |analytic - numeric| <= 1e-5 * max_i |analytic_i| for every
// coordinate (step 1e-6; central-difference truncation and round-off are ~1e-9 of that
// scale, a wrong term is off by O(1) of it).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "core/parallel.h"
#include "train/knn.h"
#include "train/losses.h"

using namespace haha;

namespace {

constexpr int H = 13, W = 11;
constexpr double kH = 1e-6, kTol = 1e-5;

std::vector<double> random_vec(size_t n, unsigned seed, double lo = 0.05, double hi = 0.95) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> v(n);
  for (double& x : v) x = u(rng);
  return v;
}

// Checks grad (analytic, for input v) against central differences of f over every
// coordinate of v.
void check_gradient(std::vector<double>& v, const std::function<double()>& f, const std::vector<double>& grad,
                    const char* what) {
  ASSERT_EQ(grad.size(), v.size());
  double scale = 0.0;
  for (double g : grad) {
    ASSERT_TRUE(std::isfinite(g)) << what;
    scale = std::max(scale, std::abs(g));
  }
  ASSERT_GT(scale, 0.0) << what << ": gradient is identically zero, the check would be empty";
  double worst = 0.0;
  for (size_t i = 0; i < v.size(); ++i) {
    const double keep = v[i];
    v[i] = keep + kH;
    const double fp = f();
    v[i] = keep - kH;
    const double fm = f();
    v[i] = keep;
    const double num = (fp - fm) / (2 * kH);
    worst = std::max(worst, std::abs(num - grad[i]) / scale);
    EXPECT_NEAR(grad[i], num, kTol * scale) << what << " coordinate " << i;
  }
  ::testing::Test::RecordProperty(what, std::to_string(worst));
}

std::vector<double> mask_with_zeros(unsigned seed) {
  std::vector<double> w = random_vec(size_t(H * W), seed, 0.0, 1.0);
  for (size_t i = 0; i < w.size(); i += 3) w[i] = 0.0;  // a third of the pixels masked out
  return w;
}

}  // namespace

// ---- L2 ----------------------------------------------------------------------------------

TEST(L2Loss, GradientMatchesFiniteDifferences) {
  auto x = random_vec(H * W * 3, 1), y = random_vec(H * W * 3, 2);
  auto w = mask_with_zeros(3);
  for (const double* weights : {static_cast<const double*>(nullptr), static_cast<const double*>(w.data())}) {
    std::vector<double> g(x.size(), 0.0);
    l2_loss<double>(x.data(), y.data(), H, W, weights, g.data(), 1.0);
    check_gradient(x, [&] { return l2_loss<double>(x.data(), y.data(), H, W, weights); }, g,
                   weights ? "l2_masked" : "l2");
  }
}

TEST(L2Loss, KnownValueZeroAtEqualityAndGradScaleAccumulates) {
  std::vector<double> x(H * W * 3, 0.5), y(H * W * 3, 0.25);
  EXPECT_NEAR(l2_loss<double>(x.data(), y.data(), H, W), 0.0625, 1e-15);
  EXPECT_EQ(l2_loss<double>(x.data(), x.data(), H, W), 0.0);
  std::vector<double> g(x.size(), 1.0);  // accumulates on top of what is there
  l2_loss<double>(x.data(), y.data(), H, W, nullptr, g.data(), 3.0);
  EXPECT_NEAR(g[0], 1.0 + 3.0 * 2.0 * 0.25 / (H * W * 3), 1e-15);
}

TEST(L2Loss, MaskedPixelsAreIgnored) {
  auto x = random_vec(H * W * 3, 4), y = random_vec(H * W * 3, 5);
  auto w = mask_with_zeros(6);
  std::vector<double> g1(x.size(), 0.0);
  const double a = l2_loss<double>(x.data(), y.data(), H, W, w.data(), g1.data());
  // Changing a masked pixel changes neither the value nor any gradient.
  auto y2 = y;
  for (size_t p = 0; p < w.size(); ++p)
    if (w[p] == 0.0)
      for (int c = 0; c < 3; ++c) y2[3 * p + c] = 1.0 - y2[3 * p + c];
  std::vector<double> g2(x.size(), 0.0);
  const double b = l2_loss<double>(x.data(), y2.data(), H, W, w.data(), g2.data());
  EXPECT_EQ(a, b);
  EXPECT_EQ(g1, g2);
  for (size_t p = 0; p < w.size(); ++p)
    if (w[p] == 0.0) {
      EXPECT_EQ(g1[3 * p], 0.0);
    }
  // A binary mask gives the mean over the kept pixels.
  std::vector<double> m(H * W, 0.0);
  m[7] = 1.0;
  double e = 0.0;
  for (int c = 0; c < 3; ++c) e += (x[21 + c] - y[21 + c]) * (x[21 + c] - y[21 + c]);
  EXPECT_NEAR(l2_loss<double>(x.data(), y.data(), H, W, m.data()), e / 3.0, 1e-15);
  // An empty mask is defined: 0 and no gradient.
  std::vector<double> zero(H * W, 0.0), g3(x.size(), 0.0);
  EXPECT_EQ(l2_loss<double>(x.data(), y.data(), H, W, zero.data(), g3.data()), 0.0);
  EXPECT_EQ(g3, std::vector<double>(x.size(), 0.0));
}

// ---- SSIM ----------------------------------------------------------------------------------

namespace {
// Direct 2D definition (11 x 11 window, zero padding), independent of the separable code.
double ssim_reference(const std::vector<double>& x, const std::vector<double>& y, int h, int w, bool valid_only) {
  double g[11], s = 0;
  for (int k = 0; k < 11; ++k) s += g[k] = std::exp(-(k - 5) * (k - 5) / (2 * 1.5 * 1.5));
  for (double& v : g) v /= s;
  double total = 0;
  int count = 0;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j) {
        if (valid_only && (i < 5 || j < 5 || i >= h - 5 || j >= w - 5)) continue;
        double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
        for (int a = -5; a <= 5; ++a)
          for (int b = -5; b <= 5; ++b) {
            const int r = i + a, q = j + b;
            if (r < 0 || r >= h || q < 0 || q >= w) continue;
            const double k = g[a + 5] * g[b + 5], u = x[(r * w + q) * 3 + c], v = y[(r * w + q) * 3 + c];
            mx += k * u;
            my += k * v;
            xx += k * u * u;
            yy += k * v * v;
            xy += k * u * v;
          }
        const double C1 = 1e-4, C2 = 9e-4;
        total += (2 * mx * my + C1) * (2 * (xy - mx * my) + C2) /
                 ((mx * mx + my * my + C1) * (xx - mx * mx + yy - my * my + C2));
        ++count;
      }
  return total / count;
}
}  // namespace

TEST(SsimLoss, GradientMatchesFiniteDifferences) {
  auto x = random_vec(H * W * 3, 7), y = random_vec(H * W * 3, 8);
  auto w = mask_with_zeros(9);
  LossScratch<double> scratch;
  for (const double* weights : {static_cast<const double*>(nullptr), static_cast<const double*>(w.data())}) {
    std::vector<double> g(x.size(), 0.0);
    ssim_loss<double>(x.data(), y.data(), H, W, scratch, weights, g.data());
    check_gradient(x, [&] { return ssim_loss<double>(x.data(), y.data(), H, W, scratch, weights); }, g,
                   weights ? "ssim_masked" : "ssim");
  }
}

TEST(SsimLoss, MatchesDirectDefinition) {
  // 24 x 17 so that the valid (window inside) region is not empty.
  const int h = 24, w = 17;
  auto x = random_vec(size_t(h * w * 3), 10), y = random_vec(size_t(h * w * 3), 11);
  LossScratch<double> scratch;
  EXPECT_NEAR(1.0 - ssim_loss<double>(x.data(), y.data(), h, w, scratch), ssim_reference(x, y, h, w, false), 1e-12);
  std::vector<float> xf(x.begin(), x.end()), yf(y.begin(), y.end());
  std::vector<double> xr(xf.begin(), xf.end()), yr(yf.begin(), yf.end());
  EXPECT_NEAR(ssim_metric(xf.data(), yf.data(), h, w, false), ssim_reference(xr, yr, h, w, false), 1e-12);
  EXPECT_NEAR(ssim_metric(xf.data(), yf.data(), h, w, true), ssim_reference(xr, yr, h, w, true), 1e-12);
  // The float training path agrees with double to float precision.
  LossScratch<float> sf;
  EXPECT_NEAR(ssim_loss<float>(xf.data(), yf.data(), h, w, sf), 1.0 - ssim_reference(xr, yr, h, w, false), 1e-5);
}

TEST(SsimLoss, EqualImagesGiveOneWithZeroGradientAndSymmetry) {
  auto x = random_vec(H * W * 3, 12), y = random_vec(H * W * 3, 13);
  LossScratch<double> scratch;
  std::vector<double> g(x.size(), 0.0);
  EXPECT_NEAR(ssim_loss<double>(x.data(), x.data(), H, W, scratch, nullptr, g.data()), 0.0, 1e-15);
  for (double v : g) EXPECT_NEAR(v, 0.0, 1e-12);  // SSIM is maximal at x = y
  std::vector<float> xf(x.begin(), x.end()), yf(y.begin(), y.end());
  EXPECT_NEAR(ssim_metric(xf.data(), xf.data(), H, W), 1.0, 1e-15);
  EXPECT_NEAR(ssim_metric(xf.data(), yf.data(), H, W), ssim_metric(yf.data(), xf.data(), H, W), 1e-15);
  EXPECT_LT(ssim_metric(xf.data(), yf.data(), H, W), 0.5);  // independent noise images
  // Constant images: finite, and 1 for equal ones (C1, C2 keep the ratio defined).
  std::vector<double> c(H * W * 3, 0.0);
  std::vector<double> gc(c.size(), 0.0);
  EXPECT_NEAR(ssim_loss<double>(c.data(), c.data(), H, W, scratch, nullptr, gc.data()), 0.0, 1e-15);
  for (double v : gc) EXPECT_TRUE(std::isfinite(v));
}

TEST(SsimLoss, TinyImagesAndEmptyMaskAreDefined) {
  auto x = random_vec(3, 14), y = random_vec(3, 15);  // 1 x 1
  LossScratch<double> scratch;
  std::vector<double> g(3, 0.0);
  const double l = ssim_loss<double>(x.data(), y.data(), 1, 1, scratch, nullptr, g.data());
  EXPECT_TRUE(std::isfinite(l));
  for (double v : g) EXPECT_TRUE(std::isfinite(v));
  std::vector<double> zero(1, 0.0);
  EXPECT_EQ(ssim_loss<double>(x.data(), y.data(), 1, 1, scratch, zero.data()), 0.0);
}

// ---- PSNR -----------------------------------------------------------------------------------

TEST(Psnr, KnownValues) {
  auto x = random_vec(H * W * 3, 16, 0.2, 0.8);
  std::vector<float> a(x.begin(), x.end()), b = a;
  for (float& v : b) v += 0.1f;  // MSE 0.01 -> 20 dB
  EXPECT_NEAR(psnr(a.data(), b.data(), H, W), 20.0, 1e-4);
  for (size_t i = 0; i < b.size(); ++i) b[i] = a[i] + (i % 2 ? 0.01f : -0.01f);  // MSE 1e-4 -> 40 dB
  EXPECT_NEAR(psnr(a.data(), b.data(), H, W), 40.0, 1e-3);
  EXPECT_EQ(psnr(a.data(), a.data(), H, W), std::numeric_limits<double>::infinity());
  std::vector<float> black(a.size(), 0.0f), white(a.size(), 1.0f);
  EXPECT_NEAR(psnr(black.data(), white.data(), H, W), 0.0, 1e-12);
  // Masked: only the kept pixels count.
  std::vector<float> m(H * W, 0.0f);
  m[0] = 1.0f;
  b = a;
  b[0] += 0.1f;
  b[1] += 0.1f;
  b[2] += 0.1f;
  b[3] += 0.5f;  // outside the mask
  EXPECT_NEAR(psnr(a.data(), b.data(), H, W, m.data()), 20.0, 1e-4);
}

// ---- edge loss --------------------------------------------------------------------------------

TEST(EdgeLoss, GradientMatchesFiniteDifferences) {
  auto x = random_vec(H * W * 3, 17), y = random_vec(H * W * 3, 18);
  auto w = mask_with_zeros(19);
  LossScratch<double> scratch;
  for (const double* weights : {static_cast<const double*>(nullptr), static_cast<const double*>(w.data())}) {
    std::vector<double> g(x.size(), 0.0);
    edge_loss<double>(x.data(), y.data(), H, W, scratch, weights, g.data());
    check_gradient(x, [&] { return edge_loss<double>(x.data(), y.data(), H, W, scratch, weights); }, g,
                   weights ? "edge_masked" : "edge");
  }
}

TEST(EdgeLoss, BorderHandlingAndKnownValue) {
  // Horizontal luminance ramp l(j) = a j against a flat image. Interior columns see the
  // central difference 2a, the two border columns the one-sided a (clamped indices).
  const int h = 4, w = 6;
  const double a = 0.01;
  const double lum = 0.257 + 0.504 + 0.098;
  std::vector<double> x(size_t(h * w * 3)), y(size_t(h * w * 3), 0.3);
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j)
      for (int c = 0; c < 3; ++c) x[size_t((i * w + j) * 3 + c)] = 0.2 + a * j / lum;
  const double flat = std::sqrt(1e-6);
  const double inner = std::sqrt(4 * a * a + 1e-6) - flat, border = std::sqrt(a * a + 1e-6) - flat;
  const double expected = (2 * border + (w - 2) * inner) / w;
  LossScratch<double> scratch;
  EXPECT_NEAR(edge_loss<double>(x.data(), y.data(), h, w, scratch), expected, 1e-12);
  // Equal images, and images differing by a constant colour, have no edge difference.
  EXPECT_EQ(edge_loss<double>(x.data(), x.data(), h, w, scratch), 0.0);
  auto z = x;
  for (double& v : z) v += 0.1;
  EXPECT_NEAR(edge_loss<double>(x.data(), z.data(), h, w, scratch), 0.0, 1e-12);
  // 1 x 1 and 1 x N images are defined.
  std::vector<double> g(3, 0.0);
  EXPECT_EQ(edge_loss<double>(x.data(), y.data(), 1, 1, scratch, nullptr, g.data()), 0.0);
  EXPECT_EQ(g, std::vector<double>(3, 0.0));
}

// ---- Dice ---------------------------------------------------------------------------------------

TEST(DiceLoss, GradientMatchesFiniteDifferences) {
  auto p = random_vec(H * W, 20, 0.0, 1.0), t = random_vec(H * W, 21, 0.0, 1.0);
  std::vector<double> g(p.size(), 0.0);
  dice_loss<double>(p.data(), t.data(), int64_t(p.size()), g.data());
  check_gradient(p, [&] { return dice_loss<double>(p.data(), t.data(), int64_t(p.size())); }, g, "dice");
}

TEST(DiceLoss, KnownValues) {
  std::vector<double> t(100, 0.0), p(100, 0.0);
  for (int i = 0; i < 30; ++i) t[size_t(i)] = 1.0;
  EXPECT_EQ(dice_loss<double>(t.data(), t.data(), 100), 0.0);  // perfect match
  EXPECT_EQ(dice_loss<double>(p.data(), p.data(), 100), 0.0);  // both empty: smoothing gives 1
  for (int i = 50; i < 70; ++i) p[size_t(i)] = 1.0;             // disjoint
  EXPECT_NEAR(dice_loss<double>(p.data(), t.data(), 100), 1.0 - 1.0 / 51.0, 1e-15);
  std::vector<float> pf(p.begin(), p.end()), tf(t.begin(), t.end());
  EXPECT_NEAR(dice_loss<float>(pf.data(), tf.data(), 100), 1.0 - 1.0 / 51.0, 1e-6);
}

// ---- texture TV -----------------------------------------------------------------------------------

TEST(TextureTv, GradientMatchesFiniteDifferences) {
  auto t = random_vec(H * W * 3, 22);
  std::vector<double> g(t.size(), 0.0);
  texture_tv_loss<double>(t.data(), H, W, 3, g.data());
  check_gradient(t, [&] { return texture_tv_loss<double>(t.data(), H, W, 3); }, g, "tv");
}

TEST(TextureTv, KnownValues) {
  std::vector<double> c(H * W * 3, 0.4), g(c.size(), 0.0);
  EXPECT_EQ(texture_tv_loss<double>(c.data(), H, W, 3, g.data()), 0.0);
  EXPECT_EQ(g, std::vector<double>(c.size(), 0.0));
  // Checkerboard of amplitude 1 in one channel: every neighbour pair differs by 1.
  const int h = 4, w = 5, C = 2;
  std::vector<double> t(size_t(h * w * C), 0.0);
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j) t[size_t((i * w + j) * C)] = (i + j) % 2;
  const double pairs = double(h * (w - 1) + (h - 1) * w);
  EXPECT_NEAR(texture_tv_loss<double>(t.data(), h, w, C), pairs / (h * w * C), 1e-15);
}

// ---- opacity regulariser ------------------------------------------------------------------------------

TEST(OpacityReg, GradientMatchesFiniteDifferencesBothModes) {
  auto o = random_vec(57, 23, 0.01, 0.99);
  for (OpacityRegMode mode : {OpacityRegMode::SumSquares, OpacityRegMode::MeanAbs}) {
    std::vector<double> g(o.size(), 0.0);
    opacity_reg<double>(o.data(), int64_t(o.size()), mode, g.data());
    check_gradient(o, [&] { return opacity_reg<double>(o.data(), int64_t(o.size()), mode); }, g,
                   mode == OpacityRegMode::SumSquares ? "opacity_sum_sq" : "opacity_mean_abs");
  }
}

TEST(OpacityReg, KnownValues) {
  std::vector<double> o = {0.5, 0.25, 0.0, 1.0};
  EXPECT_NEAR(opacity_reg<double>(o.data(), 4, OpacityRegMode::SumSquares), 0.25 + 0.0625 + 1.0, 1e-15);
  EXPECT_NEAR(opacity_reg<double>(o.data(), 4, OpacityRegMode::MeanAbs), 1.75 / 4, 1e-15);
  EXPECT_EQ(opacity_reg<double>(o.data(), 0, OpacityRegMode::MeanAbs), 0.0);
  std::vector<double> g(4, 0.0);
  opacity_reg<double>(o.data(), 4, OpacityRegMode::MeanAbs, g.data());
  EXPECT_EQ(g[2], 0.0);  // subgradient at 0
}

// ---- stretch regulariser ------------------------------------------------------------------------------

namespace {
struct StretchCase {
  int64_t n = 31;
  std::vector<int32_t> face;
  std::vector<float> stretch = {0.0f, 0.3f, 1.2f, 0.05f};  // face 0 does not stretch
  std::vector<double> offset, scale;
  explicit StretchCase(unsigned seed) {
    for (int64_t i = 0; i < n; ++i) face.push_back(int32_t(i % 4));
    offset = random_vec(size_t(3 * n), seed, -1.0, 1.0);
    scale = random_vec(size_t(3 * n), seed + 1, 0.001, 0.1);
  }
  double value() { return stretch_reg<double>(face.data(), stretch.data(), offset.data(), scale.data(), n); }
};
}  // namespace

TEST(StretchReg, GradientMatchesFiniteDifferencesForOffsetsAndScales) {
  StretchCase c(31);
  std::vector<double> go(c.offset.size(), 0.0), gs(c.scale.size(), 0.0);
  stretch_reg<double>(c.face.data(), c.stretch.data(), c.offset.data(), c.scale.data(), c.n, go.data(), gs.data());
  check_gradient(c.offset, [&] { return c.value(); }, go, "stretch_offset");
  check_gradient(c.scale, [&] { return c.value(); }, gs, "stretch_scale");
}

TEST(StretchReg, KnownValueAndNonStretchingFacesAreFree) {
  std::vector<int32_t> face = {0, 1};
  std::vector<float> stretch = {0.0f, 0.5f};
  std::vector<double> offset = {3, 4, 0, 1, 2, 2}, scale = {9, 9, 9, 0.1, 0.2, 0.2};
  // Gaussian 0 sits on a face that does not stretch: nothing, whatever its size.
  EXPECT_NEAR(stretch_reg<double>(face.data(), stretch.data(), offset.data(), scale.data(), 2),
              0.5 * (1 + 4 + 4 + 0.01 + 0.04 + 0.04) / 2, 1e-15);
  std::vector<double> go(6, 0.0), gs(6, 0.0);
  stretch_reg<double>(face.data(), stretch.data(), offset.data(), scale.data(), 2, go.data(), gs.data(), 2.0);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(go[size_t(c)], 0.0);
    EXPECT_EQ(gs[size_t(c)], 0.0);
    EXPECT_NEAR(go[size_t(3 + c)], 2.0 * 0.5 * 2 * offset[size_t(3 + c)] / 2, 1e-15);  // grad_k * w * 2 x / n
  }
  // Only one of the two gradients asked for; no Gaussians at all.
  std::vector<double> g2(6, 0.0);
  stretch_reg<double>(face.data(), stretch.data(), offset.data(), scale.data(), 2, nullptr, g2.data());
  for (size_t i = 0; i < 6; ++i) EXPECT_NEAR(g2[i], 0.5 * gs[i], 1e-15) << "grad_k 1 vs 2, value " << i;
  EXPECT_EQ(stretch_reg<double>(face.data(), stretch.data(), offset.data(), scale.data(), 0), 0.0);
}

// ---- KNN regulariser ------------------------------------------------------------------------------------

namespace {
struct KnnCase {
  int64_t n = 40;
  std::vector<double> pos, rot, scale, opac, col;
  std::vector<int32_t> sets;
  explicit KnnCase(unsigned seed) {
    pos = random_vec(size_t(3 * n), seed, -1.0, 1.0);
    rot = random_vec(size_t(4 * n), seed + 1, -1.0, 1.0);
    scale = random_vec(size_t(3 * n), seed + 2);
    opac = random_vec(size_t(n), seed + 3);
    col = random_vec(size_t(3 * n), seed + 4);
    std::vector<float> pf(pos.begin(), pos.end());
    sets.resize(size_t(3 * n));
    knn_sets(pf.data(), n, 3, sets.data());  // then held fixed
  }
  KnnRegInputs<double> inputs() const { return {n, pos.data(), rot.data(), scale.data(), opac.data(), col.data()}; }
};
}  // namespace

TEST(KnnReg, GradientMatchesFiniteDifferencesForEveryAttribute) {
  KnnCase k(30);
  const KnnRegWeights w{0.7, 1.3, 0.9, 1.1, 2.0};
  std::vector<double> gp(k.pos.size(), 0.0), gr(k.rot.size(), 0.0), gs(k.scale.size(), 0.0),
      go(k.opac.size(), 0.0), gc(k.col.size(), 0.0);
  KnnRegGrads<double> grads{gp.data(), gr.data(), gs.data(), go.data(), gc.data()};
  knn_reg<double>(k.inputs(), k.sets.data(), 3, w, &grads);
  auto f = [&] { return knn_reg<double>(k.inputs(), k.sets.data(), 3, w); };
  check_gradient(k.pos, f, gp, "knn_position");
  check_gradient(k.rot, f, gr, "knn_rotation");
  check_gradient(k.scale, f, gs, "knn_scale");
  check_gradient(k.opac, f, go, "knn_opacity");
  check_gradient(k.col, f, gc, "knn_colour");
}

TEST(KnnReg, MatchesTheDefinitionOnOneSet) {
  // Three Gaussians in one set, the other two sets empty (-1): hand-computable.
  std::vector<double> pos = {0, 0, 0, 1, 0, 0, 0, 2, 0};
  std::vector<double> opac = {0.2, 0.4, 0.9};
  std::vector<int32_t> sets = {0, 1, 2, -1, -1, -1, -1, -1, -1};
  KnnRegInputs<double> in{3, pos.data(), nullptr, nullptr, opac.data(), nullptr};
  const double mean = 0.5, var = ((0.2 - mean) * (0.2 - mean) + (0.4 - mean) * (0.4 - mean) + 0.16) / 2.0;
  const double expected_std = std::sqrt(var) / 3.0;  // mean over the 3 sets, two of them empty
  const double expected_dist = (0.0 + 1.0 + 4.0) / (3.0 * 3.0);
  KnnRegWeights only_opacity{0, 0, 1, 0, 0}, only_distance{0, 0, 0, 0, 1};
  EXPECT_NEAR(knn_reg<double>(in, sets.data(), 3, only_opacity), expected_std, 1e-9);
  EXPECT_NEAR(knn_reg<double>(in, sets.data(), 3, only_distance), expected_dist, 1e-15);
}

TEST(KnnReg, EqualAttributesGiveZeroWithFiniteGradient) {
  KnnCase k(40);
  for (double& v : k.rot) v = 0.5;
  for (double& v : k.scale) v = 0.1;
  for (double& v : k.opac) v = 0.9;
  for (double& v : k.col) v = 0.3;
  std::vector<double> g(k.rot.size(), 0.0);
  KnnRegGrads<double> grads{nullptr, g.data(), nullptr, nullptr, nullptr};
  const KnnRegWeights no_distance{1, 1, 1, 1, 0};
  EXPECT_EQ(knn_reg<double>(k.inputs(), k.sets.data(), 3, no_distance, &grads), 0.0);
  for (double v : g) EXPECT_EQ(v, 0.0);
  // Out-of-range and negative set entries are skipped, not read.
  std::vector<int32_t> bad(k.sets.size(), -1);
  bad[0] = 0;
  bad[1] = int32_t(k.n) + 5;
  EXPECT_EQ(knn_reg<double>(k.inputs(), bad.data(), 3), 0.0);
  EXPECT_EQ(knn_reg<double>(k.inputs(), k.sets.data(), 0), 0.0);
}

// ---- determinism -----------------------------------------------------------------------------------------

TEST(Losses, ResultsDoNotDependOnTheThreadCount) {
  // 256 x 256 is above the size where the loops go parallel.
  const int h = 256, w = 256;
  auto xd = random_vec(size_t(h * w * 3), 50), yd = random_vec(size_t(h * w * 3), 51), md = random_vec(size_t(h * w), 52);
  std::vector<float> x(xd.begin(), xd.end()), y(yd.begin(), yd.end()), m(md.begin(), md.end());
  auto run = [&](int threads) {
    set_num_threads(threads);
    LossScratch<float> scratch;
    std::vector<float> g(x.size(), 0.f);
    std::vector<float> out;
    out.push_back(l2_loss<float>(x.data(), y.data(), h, w, m.data(), g.data()));
    out.push_back(ssim_loss<float>(x.data(), y.data(), h, w, scratch, m.data(), g.data()));
    out.push_back(edge_loss<float>(x.data(), y.data(), h, w, scratch, nullptr, g.data()));
    out.push_back(texture_tv_loss<float>(x.data(), h, w, 3, g.data()));
    out.push_back(dice_loss<float>(x.data(), y.data(), int64_t(x.size()), g.data()));
    out.insert(out.end(), g.begin(), g.end());
    return out;
  };
  const int keep = num_threads();
  const auto one = run(1), two = run(2);
  set_num_threads(keep);
  EXPECT_EQ(one, two);
}
