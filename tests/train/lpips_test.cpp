// LPIPS network code on miniature nets whose random weights the test generates (the real
// weights are never available here): metric properties, a finite-difference gradient
// check in double, float/double agreement, the architecture's size limits, and clear
// errors for bad weight sets.
//
// Gradient tolerance: |analytic - numeric| <= 1e-5 * max |analytic| over every other
// input coordinate (step 1e-6, central differences).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/parallel.h"
#include "support/expect_error.h"
#include "support/lpips_mini_weights.h"
#include "train/image_loss.h"
#include "train/lpips.h"

using namespace haha;
using haha::test::expect_error;
using haha::test::make_weights;

namespace {

std::vector<double> random_image(int h, int w, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> v(size_t(h * w * 3));
  for (double& x : v) x = u(rng);
  return v;
}

// The definition written out naively (bounds-checked loops, no blocking, no padding
// buffers): conv + ReLU, max-pool, taps; lpips scaling, channel normalisation, heads.
struct Tensor3 {
  int c, h, w;
  std::vector<double> v;
  double& at(int k, int i, int j) { return v[size_t((k * h + i) * w + j)]; }
};
std::vector<Tensor3> reference_taps(const LpipsWeights& wts, LpipsBackbone b, const std::vector<double>& img, int H,
                                    int W) {
  const double shift[3] = {-.030, -.088, -.188}, scale[3] = {.458, .448, .450};
  Tensor3 t{3, H, W, std::vector<double>(size_t(3 * H * W))};
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < W; ++j)
      for (int c = 0; c < 3; ++c) t.at(c, i, j) = (2 * img[size_t((i * W + j) * 3 + c)] - 1 - shift[c]) / scale[c];
  struct Step {
    char kind;
    int a, s, p;
  };
  const std::vector<Step> alex = {{'C', 0, 4, 2}, {'T', 0, 0, 0}, {'P', 3, 2, 0},  {'C', 3, 1, 2},
                                  {'T', 0, 0, 0}, {'P', 3, 2, 0}, {'C', 6, 1, 1},  {'T', 0, 0, 0},
                                  {'C', 8, 1, 1}, {'T', 0, 0, 0}, {'C', 10, 1, 1}, {'T', 0, 0, 0}};
  std::vector<Step> vgg;
  int idx = 0;
  for (int block : {2, 2, 3, 3, 3}) {
    if (idx > 0) {
      vgg.push_back({'P', 2, 2, 0});
      ++idx;
    }
    for (int r = 0; r < block; ++r, idx += 2) vgg.push_back({'C', idx, 1, 1});
    vgg.push_back({'T', 0, 0, 0});
  }
  std::vector<Tensor3> taps;
  const std::string pre = lpips_prefix(b);
  for (const Step& st : b == LpipsBackbone::Alex ? alex : vgg) {
    if (st.kind == 'T') {
      taps.push_back(t);
    } else if (st.kind == 'P') {
      Tensor3 o{t.c, (t.h - st.a) / st.s + 1, (t.w - st.a) / st.s + 1, {}};
      o.v.assign(size_t(o.c * o.h * o.w), 0.0);
      for (int c = 0; c < o.c; ++c)
        for (int i = 0; i < o.h; ++i)
          for (int j = 0; j < o.w; ++j) {
            double m = -1e300;
            for (int a = 0; a < st.a; ++a)
              for (int bb = 0; bb < st.a; ++bb) m = std::max(m, t.at(c, i * st.s + a, j * st.s + bb));
            o.at(c, i, j) = m;
          }
      t = o;
    } else {
      const LpipsTensor& wt = wts.tensors.at(pre + ".features." + std::to_string(st.a) + ".weight");
      const LpipsTensor& bt = wts.tensors.at(pre + ".features." + std::to_string(st.a) + ".bias");
      const int O = int(wt.shape[0]), C = int(wt.shape[1]), kh = int(wt.shape[2]), kw = int(wt.shape[3]);
      Tensor3 o{O, (t.h + 2 * st.p - kh) / st.s + 1, (t.w + 2 * st.p - kw) / st.s + 1, {}};
      o.v.assign(size_t(o.c * o.h * o.w), 0.0);
      for (int q = 0; q < O; ++q)
        for (int i = 0; i < o.h; ++i)
          for (int j = 0; j < o.w; ++j) {
            double sum = bt.data[size_t(q)];
            for (int c = 0; c < C; ++c)
              for (int a = 0; a < kh; ++a)
                for (int bb = 0; bb < kw; ++bb) {
                  const int ii = i * st.s + a - st.p, jj = j * st.s + bb - st.p;
                  if (ii < 0 || jj < 0 || ii >= t.h || jj >= t.w) continue;
                  sum += double(wt.data[size_t(((q * C + c) * kh + a) * kw + bb)]) * t.at(c, ii, jj);
                }
            o.at(q, i, j) = std::max(sum, 0.0);
          }
      t = o;
    }
  }
  return taps;
}

double reference_lpips(const LpipsWeights& wts, LpipsBackbone b, const std::vector<double>& x,
                       const std::vector<double>& y, int H, int W) {
  auto tx = reference_taps(wts, b, x, H, W), ty = reference_taps(wts, b, y, H, W);
  double d = 0;
  for (size_t l = 0; l < tx.size(); ++l) {
    const LpipsTensor& lin = wts.tensors.at(std::string(lpips_prefix(b)) + ".lin." + std::to_string(l) + ".weight");
    double s = 0;
    for (int i = 0; i < tx[l].h; ++i)
      for (int j = 0; j < tx[l].w; ++j) {
        double nx = 0, ny = 0;
        for (int c = 0; c < tx[l].c; ++c) {
          nx += tx[l].at(c, i, j) * tx[l].at(c, i, j);
          ny += ty[l].at(c, i, j) * ty[l].at(c, i, j);
        }
        nx = std::sqrt(nx) + 1e-10;
        ny = std::sqrt(ny) + 1e-10;
        for (int c = 0; c < tx[l].c; ++c) {
          const double e = tx[l].at(c, i, j) / nx - ty[l].at(c, i, j) / ny;
          s += lin.data[size_t(c)] * e * e;
        }
      }
    d += s / (tx[l].h * tx[l].w);
  }
  return d;
}

}  // namespace

TEST(Lpips, MatchesTheNaiveDefinition) {
  for (LpipsBackbone b : {LpipsBackbone::Alex, LpipsBackbone::Vgg16}) {
    const auto w = make_weights(b, 11);
    LpipsNet<double> net(w, b);
    // Odd sizes: partial 8-column blocks, pools that drop a border row / column.
    const int h = net.min_size() + 9, wd = net.min_size() + 14;
    auto x = random_image(h, wd, 12), y = random_image(h, wd, 13);
    const double ref = reference_lpips(w, b, x, y, h, wd);
    EXPECT_GT(ref, 0.0);
    EXPECT_NEAR(net.distance(x.data(), y.data(), h, wd), ref, 1e-12 * ref) << lpips_prefix(b);
  }
}

TEST(Lpips, MetricPropertiesBothBackbones) {
  for (LpipsBackbone b : {LpipsBackbone::Alex, LpipsBackbone::Vgg16}) {
    LpipsNet<double> net(make_weights(b, 1), b);
    const int n = net.min_size() + 5;
    auto x = random_image(n, n + 3, 2), y = random_image(n, n + 3, 3);
    EXPECT_EQ(net.distance(x.data(), x.data(), n, n + 3), 0.0);
    const double dxy = net.distance(x.data(), y.data(), n, n + 3);
    EXPECT_GT(dxy, 0.0);
    EXPECT_EQ(dxy, net.distance(y.data(), x.data(), n, n + 3));
    // A small perturbation is closer than an unrelated image.
    auto z = x;
    for (double& v : z) v = std::min(1.0, v + 0.01);
    EXPECT_LT(net.distance(x.data(), z.data(), n, n + 3), dxy);
    // The float path agrees with double.
    LpipsNet<float> netf(make_weights(b, 1), b);
    std::vector<float> xf(x.begin(), x.end()), yf(y.begin(), y.end());
    EXPECT_NEAR(netf.distance(xf.data(), yf.data(), n, n + 3), dxy, 1e-5 * dxy);
  }
}

TEST(Lpips, GradientMatchesFiniteDifferences) {
  for (LpipsBackbone b : {LpipsBackbone::Alex, LpipsBackbone::Vgg16}) {
    LpipsNet<double> net(make_weights(b, 4), b);
    const int h = net.min_size() + 2, w = net.min_size() + 1;
    auto x = random_image(h, w, 5), y = random_image(h, w, 6);
    std::vector<double> g(x.size(), 0.0);
    const double d0 = net.distance(x.data(), y.data(), h, w, g.data(), 1.0);
    EXPECT_EQ(d0, net.distance(x.data(), y.data(), h, w));  // the gradient pass leaves the value
    double scale = 0.0;
    for (double v : g) {
      ASSERT_TRUE(std::isfinite(v));
      scale = std::max(scale, std::abs(v));
    }
    ASSERT_GT(scale, 0.0);
    const double step = 1e-6;
    for (size_t i = 0; i < x.size(); i += 2) {  // every other coordinate: all pixels' channels mix
      const double keep = x[i];
      x[i] = keep + step;
      const double fp = net.distance(x.data(), y.data(), h, w);
      x[i] = keep - step;
      const double fm = net.distance(x.data(), y.data(), h, w);
      x[i] = keep;
      EXPECT_NEAR(g[i], (fp - fm) / (2 * step), 1e-5 * scale) << lpips_prefix(b) << " coordinate " << i;
    }
    // grad_scale scales and accumulates.
    std::vector<double> g2(x.size(), 1.0);
    net.distance(x.data(), y.data(), h, w, g2.data(), -2.0);
    for (size_t i = 0; i < x.size(); i += 17) EXPECT_NEAR(g2[i], 1.0 - 2.0 * g[i], 1e-12);
  }
}

TEST(Lpips, ArchitectureSizeLimits) {
  // Real kernel sizes: AlexNet needs 31 px (conv 11/4 then two 3/2 pools), VGG16 16 px
  // (four 2/2 pools).
  LpipsNet<float> alex(make_weights(LpipsBackbone::Alex, 7), LpipsBackbone::Alex);
  LpipsNet<float> vgg(make_weights(LpipsBackbone::Vgg16, 7), LpipsBackbone::Vgg16);
  EXPECT_EQ(alex.min_size(), 31);
  EXPECT_EQ(vgg.min_size(), 16);
  std::vector<float> img(15 * 15 * 3, 0.5f);
  expect_error([&] { vgg.distance(img.data(), img.data(), 15, 15); }, "mini.npz", "smaller");
}

TEST(Lpips, BadWeightsNameTheFileAndKey) {
  const auto b = LpipsBackbone::Alex;
  auto w = make_weights(b, 8, "/some/lpips.npz");
  EXPECT_TRUE(w.has_backbone(LpipsBackbone::Alex));
  EXPECT_FALSE(w.has_backbone(LpipsBackbone::Vgg16));
  {
    auto m = w;
    m.tensors.erase("alex.features.6.weight");
    expect_error([&] { LpipsNet<float> n(m, b); }, "/some/lpips.npz", "alex.features.6.weight: missing");
  }
  {
    auto m = w;
    m.tensors.erase("alex.lin.4.weight");
    expect_error([&] { LpipsNet<float> n(m, b); }, "/some/lpips.npz", "alex.lin.4.weight: missing");
  }
  {
    auto m = w;  // input channels of conv 3 do not chain from conv 0's 4 outputs
    m.tensors["alex.features.3.weight"] = LpipsTensor{{5, 3, 5, 5}, std::vector<float>(5 * 3 * 25, 0.f)};
    expect_error([&] { LpipsNet<float> n(m, b); }, "alex.features.3.weight", "expected shape (out, 4, kh, kw)");
  }
  {
    auto m = w;
    m.tensors["alex.features.0.bias"] = LpipsTensor{{3}, {0.f, 0.f, 0.f}};
    expect_error([&] { LpipsNet<float> n(m, b); }, "alex.features.0.bias", "expected shape (4,)");
  }
  {
    auto m = w;
    m.tensors["alex.lin.0.weight"] = LpipsTensor{{4}, {1.f, 1.f, 1.f, 1.f}};
    expect_error([&] { LpipsNet<float> n(m, b); }, "alex.lin.0.weight", "expected shape (1, 4, 1, 1)");
  }
  {
    auto m = w;
    m.tensors["alex.features.8.bias"].data.pop_back();
    expect_error([&] { LpipsNet<float> n(m, b); }, "alex.features.8.bias", "values");
  }
  // A file with only AlexNet arrays cannot build the VGG net.
  expect_error([&] { LpipsNet<float> n(w, LpipsBackbone::Vgg16); }, "/some/lpips.npz", "vgg.features.0.weight: missing");
}

TEST(Lpips, ResultsDoNotDependOnTheThreadCount) {
  // 128 x 128 is above the size where the convolutions go parallel.
  LpipsNet<float> net(make_weights(LpipsBackbone::Vgg16, 14), LpipsBackbone::Vgg16);
  auto xd = random_image(128, 128, 15), yd = random_image(128, 128, 16);
  std::vector<float> x(xd.begin(), xd.end()), y(yd.begin(), yd.end());
  auto run = [&](int threads) {
    set_num_threads(threads);
    std::vector<float> g(x.size(), 0.f);
    g.push_back(net.distance(x.data(), y.data(), 128, 128, g.data()));
    return g;
  };
  const int keep = num_threads();
  const auto one = run(1), two = run(2);
  set_num_threads(keep);
  EXPECT_EQ(one, two);
}

// The LPIPS loss on a crop around the person (train/image_loss.h), as the authors train it.
TEST(LpipsCrop, WindowLiesOnThePersonAndInsideTheImage) {
  const int H = 60, W = 80;
  std::vector<float> mask(size_t(H * W), 0.0f);
  for (int y = 20; y < 50; ++y)
    for (int x = 30; x < 40; ++x) mask[size_t(y * W + x)] = 1.0f;
  // u = v = 0: the box's top-left pixel (30, 20) is the centre of a 16 x 16 window.
  PixelWindow c = person_crop(mask.data(), H, W, 16, 0.0, 0.0);
  EXPECT_EQ(c.w, 16);
  EXPECT_EQ(c.h, 16);
  EXPECT_EQ(c.x0, 22);
  EXPECT_EQ(c.y0, 12);
  // Near the bottom-right corner of the box (39, 49): shifted only as far as the image needs.
  c = person_crop(mask.data(), H, W, 32, 0.999, 0.999);
  EXPECT_EQ(c.x0, 39 - 16);
  EXPECT_EQ(c.y0, H - 32);
  // A crop larger than the image is the image; no person or no crop size: the whole image.
  c = person_crop(mask.data(), H, W, 256, 0.5, 0.5);
  EXPECT_EQ(c.x0, 0);
  EXPECT_EQ(c.y0, 0);
  EXPECT_EQ(c.w, W);
  EXPECT_EQ(c.h, H);
  const std::vector<float> empty(size_t(H * W), 0.0f);
  c = person_crop(empty.data(), H, W, 16, 0.5, 0.5);
  EXPECT_EQ(c.w, W);
  EXPECT_EQ(c.h, H);
  c = person_crop(mask.data(), H, W, 0, 0.5, 0.5);
  EXPECT_EQ(c.w, W);
  c = person_crop(nullptr, H, W, 16, 0.5, 0.5);
  EXPECT_EQ(c.w, W);
}

TEST(LpipsCrop, LossAndGradientAreThoseOfTheCroppedImages) {
  const LpipsBackbone b = LpipsBackbone::Vgg16;
  LpipsNet<float> net(make_weights(b, 3), b);
  const int H = 40, W = 50;
  const std::vector<double> xd = random_image(H, W, 1), yd = random_image(H, W, 2);
  const std::vector<float> x(xd.begin(), xd.end()), y(yd.begin(), yd.end());
  LossWeights w;
  w.l2 = w.ssim = w.sobel = 0;
  w.lpips = 0.5;
  ImageLossContext ctx;
  ctx.lpips = &net;
  ctx.lpips_window = {7, 11, 20, 18};
  std::vector<float> grad(x.size(), 0.0f);
  LossTerms terms;
  const double v = image_loss(x.data(), y.data(), H, W, nullptr, w, ctx, grad.data(), 2.0f, terms);

  std::vector<float> xc, yc;
  for (int r = 11; r < 29; ++r)
    for (int c = 7; c < 27; ++c)
      for (int k = 0; k < 3; ++k) {
        xc.push_back(x[size_t((r * W + c) * 3 + k)]);
        yc.push_back(y[size_t((r * W + c) * 3 + k)]);
      }
  std::vector<float> gc(xc.size(), 0.0f);
  const double ref = net.distance(xc.data(), yc.data(), 18, 20, gc.data(), float(0.5 * 2.0));
  EXPECT_DOUBLE_EQ(v, 2.0 * 0.5 * ref);
  EXPECT_DOUBLE_EQ(terms.lpips, 2.0 * ref);
  size_t i = 0, nonzero = 0;
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c)
      for (int k = 0; k < 3; ++k) {
        const float g = grad[size_t((r * W + c) * 3 + k)];
        if (r >= 11 && r < 29 && c >= 7 && c < 27) {
          EXPECT_EQ(g, gc[i++]);
          nonzero += g != 0.0f;
        } else {
          ASSERT_EQ(g, 0.0f) << r << " " << c;
        }
      }
  EXPECT_GT(nonzero, gc.size() / 2);
  // The whole-image window is the plain full-frame loss.
  ctx.lpips_window = {};
  LossTerms t2;
  EXPECT_DOUBLE_EQ(image_loss(x.data(), y.data(), H, W, nullptr, w, ctx, nullptr, 1.0f, t2),
                   0.5 * double(net.distance(x.data(), y.data(), H, W)));
}
