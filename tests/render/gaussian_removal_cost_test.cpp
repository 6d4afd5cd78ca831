// The rasterizer's removal cost (GaussianGrads::removal_cost): what deleting one Gaussian
// alone changes in the composite, sum over pixels of the mean over channels of |change|.
// Checked against the brute force, the scene rendered again without that Gaussian, in
// double (exact up to rounding where the early stop does not act: opacities <= 0.6 and at
// most 8 Gaussians keep every transmittance above 0.4^8 > 1e-4), with an occlusion map, a
// per-pixel background and a backdrop other than the raster's own background (the merge's
// mesh-or-background); and its hard cases: occluded, invisible, the backdrop's own colour.
#include <gtest/gtest.h>

#include <cmath>

#include "core/parallel.h"
#include "support/render_gaussian_harness.h"

using namespace haha;
using namespace haha::testref;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<double> stripe_depth(int w, int h) {
  std::vector<double> d(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) d[size_t(y) * w + x] = x < w / 2 ? 1.7 + 0.6 * double(y) / h : kInf;
  return d;
}

std::vector<double> some_image(int w, int h, int salt) {
  std::vector<double> bg(size_t(w) * h * 3);
  for (size_t i = 0; i < bg.size(); ++i) bg[i] = 0.1 + 0.8 * double((i * 7919 + size_t(salt)) % 101) / 101;
  return bg;
}

Buffers<double> without(const Buffers<double>& b, int i) {
  Buffers<double> r = b;
  r.means.erase(r.means.begin() + 3 * i, r.means.begin() + 3 * i + 3);
  r.quats.erase(r.quats.begin() + 4 * i, r.quats.begin() + 4 * i + 4);
  r.scales.erase(r.scales.begin() + 3 * i, r.scales.begin() + 3 * i + 3);
  r.colors.erase(r.colors.begin() + 3 * i, r.colors.begin() + 3 * i + 3);
  r.opacities.erase(r.opacities.begin() + i);
  return r;
}

// Composite of `b` with its background replaced by `backdrop` when given.
std::vector<double> composite(Buffers<double> b, const CameraT<double>& cam, const std::vector<double>& backdrop) {
  if (!backdrop.empty()) b.bg = backdrop;
  GaussianRasterState<double> st;
  return run_forward(b, cam, false, st).composite;
}

// removal_cost of every Gaussian (backdrop: dout.backdrop, empty = the raster's background).
std::vector<double> removal_cost(const Buffers<double>& b, const CameraT<double>& cam,
                                 const std::vector<double>& backdrop, int calls = 1) {
  GaussianRasterState<double> st;
  run_forward(b, cam, false, st);
  const size_t n = b.opacities.size();
  std::vector<double> cost(n, 0.0), d_op(n);
  for (int k = 0; k < calls; ++k) {
    GaussianGrads<double> g;
    g.opacities = d_op.data();
    g.removal_cost = cost.data();
    GaussianRasterOutputGrads<double> dout;
    dout.backdrop = backdrop.empty() ? nullptr : backdrop.data();
    rasterize_gaussians_backward(b.inputs(), cam, settings_of(b, false), st, dout, g);
  }
  return cost;
}

std::vector<double> brute_force(const Buffers<double>& b, const CameraT<double>& cam,
                                const std::vector<double>& backdrop) {
  const std::vector<double> all = composite(b, cam, backdrop);
  std::vector<double> cost;
  for (int i = 0; i < int(b.opacities.size()); ++i) {
    const std::vector<double> rest = composite(without(b, i), cam, backdrop);
    double s = 0;
    for (size_t k = 0; k < all.size(); ++k) s += std::abs(all[k] - rest[k]) / 3;
    cost.push_back(s);
  }
  return cost;
}

void expect_near_all(const std::vector<double>& got, const std::vector<double>& want) {
  ASSERT_EQ(got.size(), want.size());
  int positive = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i], want[i], 1e-9 * std::max(1.0, want[i])) << "Gaussian " << i;
    positive += want[i] > 1e-3;
  }
  EXPECT_GE(positive, int(got.size()) / 2) << "most Gaussians should show";
}

TEST(GaussianRemovalCost, EqualsRenderingWithoutEachGaussian) {
  const auto cam = make_camera(40, 32, 36);
  for (unsigned seed : {1u, 2u, 3u}) {
    const Buffers<double> b = to_buffers<double>(random_scene(8, seed, cam, 0.04, 0.2, 0.2, 0.6),
                                                 stripe_depth(40, 32), some_image(40, 32, 0));
    expect_near_all(removal_cost(b, cam, {}), brute_force(b, cam, {}));
  }
}

TEST(GaussianRemovalCost, AgainstABackdropOtherThanTheBackground) {
  // The merge runs the raster on black and adds what lies behind itself: the cost must see
  // that backdrop, not the raster's black.
  const auto cam = make_camera(36, 30, 32);
  Buffers<double> b = to_buffers<double>(random_scene(8, 11, cam, 0.04, 0.2, 0.2, 0.6), stripe_depth(36, 30));
  const std::vector<double> backdrop = some_image(36, 30, 5);
  const std::vector<double> cost = removal_cost(b, cam, backdrop);
  expect_near_all(cost, brute_force(b, cam, backdrop));
  const std::vector<double> on_black = removal_cost(b, cam, {});
  double diff = 0;
  for (size_t i = 0; i < cost.size(); ++i) diff += std::abs(cost[i] - on_black[i]);
  EXPECT_GT(diff, 1e-3) << "the backdrop must change the cost";
}

TEST(GaussianRemovalCost, AccumulatesAcrossCalls) {
  const auto cam = make_camera(24, 20, 24);
  const Buffers<double> b = to_buffers<double>(random_scene(6, 4, cam, 0.05, 0.2, 0.2, 0.6), {}, some_image(24, 20, 1));
  const std::vector<double> once = removal_cost(b, cam, {}), twice = removal_cost(b, cam, {}, 2);
  for (size_t i = 0; i < once.size(); ++i) EXPECT_NEAR(twice[i], 2 * once[i], 1e-12 * std::max(1.0, once[i]));
}

TEST(GaussianRemovalCost, HiddenOffScreenOrTheBackdropsColourCostsNothing) {
  const auto cam = make_camera(24, 20, 24);
  Scene s = random_scene(3, 6, cam, 0.05, 0.2, 0.4, 0.6);
  // Gaussian 0 behind an occluder everywhere, 1 behind the camera, 2 the background's colour
  // alone over a uniform background.
  s.means[2] += 10.0;  // along the view axis (make_camera looks down +z)
  s.means[5] = -5.0;
  const double bgc[3] = {0.25, 0.5, 0.75};
  for (int c = 0; c < 3; ++c) s.colors[size_t(6 + c)] = bgc[c];
  const std::vector<double> wall(size_t(24) * 20, 3.0);
  Buffers<double> b = to_buffers<double>(s, wall, {}, bgc);
  const std::vector<double> cost = removal_cost(b, cam, {});
  EXPECT_EQ(cost[0], 0.0);
  EXPECT_EQ(cost[1], 0.0);
  EXPECT_NEAR(cost[2], 0.0, 1e-12);
  // Other colours over the same background do cost.
  for (int c = 0; c < 3; ++c) b.colors[size_t(6 + c)] = 1.0 - bgc[c];
  EXPECT_GT(removal_cost(b, cam, {})[2], 0.1);
}

TEST(GaussianRemovalCost, FloatMatchesDouble) {
  const auto cam = make_camera(40, 32, 36);
  const Scene s = random_scene(8, 9, cam, 0.04, 0.2, 0.2, 0.6);
  const Buffers<double> bd = to_buffers<double>(s, stripe_depth(40, 32), some_image(40, 32, 0));
  const Buffers<float> bf = to_buffers<float>(s, stripe_depth(40, 32), some_image(40, 32, 0));
  const std::vector<double> want = removal_cost(bd, cam, {});
  GaussianRasterState<float> st;
  run_forward(bf, cam, false, st);
  std::vector<float> cost(want.size(), 0.0f), d_op(want.size());
  GaussianGrads<float> g;
  g.opacities = d_op.data();
  g.removal_cost = cost.data();
  rasterize_gaussians_backward(bf.inputs(), cam.cast<float>(), settings_of(bf, false), st, {}, g);
  for (size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(cost[i], want[i], 1e-4 * std::max(1.0, want[i])) << i;
}

TEST(GaussianRemovalCost, DoesNotChangeTheGradients) {
  const auto cam = make_camera(24, 20, 24);
  const Buffers<double> b = to_buffers<double>(random_scene(6, 8, cam, 0.05, 0.2, 0.2, 0.6), {}, some_image(24, 20, 1));
  const std::vector<double> w = some_image(24, 20, 3);
  std::vector<double> with(6), plain(6), cost(6);
  for (bool want_cost : {false, true}) {
    GaussianRasterState<double> st;
    run_forward(b, cam, false, st);
    GaussianGrads<double> g;
    g.opacities = want_cost ? with.data() : plain.data();
    g.removal_cost = want_cost ? cost.data() : nullptr;
    GaussianRasterOutputGrads<double> dout;
    dout.composite = w.data();
    rasterize_gaussians_backward(b.inputs(), cam, settings_of(b, false), st, dout, g);
  }
  EXPECT_EQ(with, plain);
}

}  // namespace
