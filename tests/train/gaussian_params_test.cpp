// Gaussian parameter state: activations and their gradients (finite differences in
// double), export / import, densification (clone / split) and pruning bookkeeping, the
// counter-based random numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "core/error.h"
#include "train/adam.h"
#include "train/gaussian_params.h"

namespace haha {
namespace {

TEST(GaussianParams, ScaledSigmoidGradientMatchesFiniteDifferences) {
  // Relative tolerance 1e-8 (central differences, h = 1e-6, double).
  for (double a : {0.1, 1.0, 3.0})
    for (double x : {-30.0, -4.0, -0.3, 0.0, 0.7, 5.0, 30.0}) {
      const double h = 1e-6;
      const double fd = (scaled_sigmoid(x + h, a) - scaled_sigmoid(x - h, a)) / (2 * h);
      const double an = scaled_sigmoid_grad_from_output(scaled_sigmoid(x, a), a);
      EXPECT_NEAR(an, fd, 1e-8 * std::max(1.0, std::fabs(fd)) + 1e-12) << "a=" << a << " x=" << x;
    }
}

TEST(GaussianParams, NormalizeQuatBackwardMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  for (int t = 0; t < 20; ++t) {
    double r[4], g[4];
    const double scale = t < 10 ? 1.0 : 1e-3 * (t + 1);  // also short quaternions
    for (int i = 0; i < 4; ++i) r[i] = scale * n(rng), g[i] = n(rng);
    // L = g . normalize_quat(r): the forward and its backward together
    auto L = [&](const double* q) {
      double u[4];
      normalize_quat(q, u);
      double s = 0;
      for (int i = 0; i < 4; ++i) s += g[i] * u[i];
      return s;
    };
    double d[4];
    normalize_quat_backward(r, g, d);
    for (int i = 0; i < 4; ++i) {
      const double h = 1e-7 * scale;
      double qp[4], qm[4];
      for (int k = 0; k < 4; ++k) qp[k] = qm[k] = r[k];
      qp[i] += h;
      qm[i] -= h;
      const double fd = (L(qp) - L(qm)) / (2 * h);
      EXPECT_NEAR(d[i], fd, 1e-6 * std::max(1.0, std::fabs(fd)));
    }
  }
  // Zero quaternion: defined (finite) result.
  const double z[4] = {0, 0, 0, 0}, g[4] = {1, 2, 3, 4};
  double d[4];
  normalize_quat_backward(z, g, d);
  for (double v : d) EXPECT_TRUE(std::isfinite(v));
  normalize_quat(z, d);
  for (double v : d) EXPECT_EQ(v, 0.0);
}

TEST(GaussianParams, ActivationBackwardIsTheChainRule) {
  GaussianParams g = init_one_per_face(5, 0.02f, 0.3f, 0.9f, 0.1f);
  for (int i = 0; i < 15; ++i) g.scale_logit[size_t(i)] += 0.1f * i, g.color_logit[size_t(i)] -= 0.2f * i;
  ActivatedGaussians a;
  activate(g, 0.1f, a);
  EXPECT_NEAR(a.scale[0], 0.02f, 1e-6);
  EXPECT_NEAR(a.color[0], 0.3f, 1e-6);
  EXPECT_NEAR(a.opacity[0], 0.9f, 1e-6);
  std::vector<float> ds(15, 1.0f), dc(15, 2.0f), dop(5, -1.0f), ls(15), lc(15), lo(5);
  activation_backward(a, 0.1f, 5, ds.data(), dc.data(), dop.data(), ls.data(), lc.data(), lo.data());
  for (int i = 0; i < 15; ++i) {
    const double s = a.scale[size_t(i)], c = a.color[size_t(i)];
    EXPECT_NEAR(ls[size_t(i)], s * (1 - s / 0.1), 1e-7);
    EXPECT_NEAR(lc[size_t(i)], 2 * c * (1 - c), 1e-7);
  }
  EXPECT_NEAR(lo[0], -0.9 * 0.1, 1e-6);
}

TEST(GaussianParams, InitAndBoundRoundTrip) {
  GaussianParams g = init_one_per_face(7, 0.015f, 0.5f, 0.99f, 0.1f);
  ASSERT_EQ(g.size(), 7);
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(g.face[size_t(i)], i);
    EXPECT_EQ(g.offset[3 * size_t(i)], 0.0f);
    EXPECT_EQ(g.rotation[4 * size_t(i)], 1.0f);
  }
  g.rotation[0] = 2.0f;  // unnormalised raw quaternion: exported normalised
  const BoundGaussians b = to_bound(g, 0.1f);
  EXPECT_FLOAT_EQ(b.rotation[0], 1.0f);
  EXPECT_NEAR(b.scale[4], 0.015f, 1e-7);
  EXPECT_NEAR(b.opacity[6], 0.99f, 1e-6);
  const GaussianParams back = from_bound(b, 0.1f);
  for (size_t i = 0; i < back.scale_logit.size(); ++i) EXPECT_NEAR(back.scale_logit[i], g.scale_logit[i], 1e-4);
  // Saturated activated values stay finite.
  BoundGaussians s = b;
  s.opacity[0] = 1.0f;
  s.color[0] = 0.0f;
  s.scale[0] = 0.1f;
  const GaussianParams f = from_bound(s, 0.1f);
  EXPECT_TRUE(std::isfinite(f.opacity_logit[0]) && std::isfinite(f.color_logit[0]) && std::isfinite(f.scale_logit[0]));
}

TEST(GaussianParams, PlanDensifyChoosesByMeanGradientAndScale) {
  GaussianParams g = init_one_per_face(6, 0.002f, 0.5f, 0.99f, 0.1f);  // small: clone
  for (int k = 0; k < 3; ++k) g.scale_logit[3 * 4 + k] = logit(0.05f / 0.1f);  // big: split
  //                        0     1     2     3     4     5
  std::vector<float> acc = {1.0f, 9.0f, 4.0f, 0.0f, 8.0f, 3.0f};
  std::vector<float> cnt = {1.0f, 3.0f, 1.0f, 0.0f, 2.0f, 1.0f};  // means 1, 3, 4, -, 4, 3
  DensifyPlan p = plan_densify(g, 0.1f, acc, cnt, 3.0, 0.005, 100);
  EXPECT_EQ(p.clone, (std::vector<int64_t>{1, 2, 5}));
  EXPECT_EQ(p.split, (std::vector<int64_t>{4}));
  // Cap: only two may be added; the largest means (4, 4: indices 2 and 4) win.
  p = plan_densify(g, 0.1f, acc, cnt, 3.0, 0.005, 8);
  EXPECT_EQ(p.clone, (std::vector<int64_t>{2}));
  EXPECT_EQ(p.split, (std::vector<int64_t>{4}));
  EXPECT_THROW(plan_densify(g, 0.1f, {1.0f}, cnt, 3.0, 0.005, 100), Error);
}

TEST(GaussianParams, ApplyDensifyClonesSplitsAndKeepsFaces) {
  GaussianParams g = init_one_per_face(4, 0.04f, 0.5f, 0.99f, 0.1f);
  for (int i = 0; i < 4; ++i) {
    g.offset[3 * size_t(i)] = float(i);
    g.color_logit[3 * size_t(i)] = 0.1f * i;
    g.face[size_t(i)] = 10 + i;
  }
  // Parent 2 rotated by 90 degrees about z: its local x maps to the face's y.
  g.rotation[8] = std::cos(M_PI / 4);
  g.rotation[11] = std::sin(M_PI / 4);
  const GaussianParams old = g;
  DensifyPlan plan;
  plan.clone = {0};
  plan.split = {2};
  const DensifyResult r = apply_densify(g, plan, 0.1f, 0.5, 1.6, 42);
  ASSERT_EQ(g.size(), 6);  // 3 kept + 1 clone + 2 children of the split parent
  EXPECT_EQ(r.cloned, 1);
  EXPECT_EQ(r.split, 1);
  // Order: kept 0, 1, 3, the clone of 0, two children of 2; new ones get fresh moments.
  EXPECT_EQ(r.adam_source, (std::vector<int64_t>{0, 1, 3, -1, -1, -1}));
  EXPECT_EQ(g.face, (std::vector<int32_t>{10, 11, 13, 10, 12, 12}));
  // The clone is an exact copy.
  for (int k = 0; k < 3; ++k) EXPECT_EQ(g.offset[9 + size_t(k)], old.offset[size_t(k)]);
  EXPECT_EQ(g.color_logit[9], old.color_logit[0]);
  // Children of the rotated parent: displaced along its local axes, face-frame y >= parent's,
  // scales / 1.6, colour and rotation kept.
  for (int e = 4; e < 6; ++e) {
    EXPECT_GE(g.offset[3 * size_t(e) + 1], old.offset[7]);
    EXPECT_NEAR(scaled_sigmoid(g.scale_logit[3 * size_t(e)], 0.1f), 0.04f / 1.6f, 1e-6);
    EXPECT_EQ(g.color_logit[3 * size_t(e)], old.color_logit[6]);
    EXPECT_EQ(g.rotation[4 * size_t(e) + 3], old.rotation[11]);
  }
  EXPECT_NE(g.offset[12], g.offset[15]);  // two different samples
}

TEST(GaussianParams, SplitChildrenGoOutwardShrinkAndAreDeterministic) {
  GaussianParams g = init_one_per_face(200, 0.05f, 0.5f, 0.99f, 0.1f);
  DensifyPlan plan;
  for (int i = 0; i < 200; ++i) plan.split.push_back(i);
  GaussianParams a = g, b = g;
  apply_densify(a, plan, 0.1f, 0.5, 1.6, 7);
  apply_densify(b, plan, 0.1f, 0.5, 1.6, 7);
  ASSERT_EQ(a.size(), 400);
  EXPECT_EQ(a.offset, b.offset);  // same seed, same children
  double spread = 0;
  for (int e = 0; e < 400; ++e) {
    EXPECT_EQ(a.face[size_t(e)], e / 2);  // children keep the parent face
    EXPECT_GE(a.offset[3 * size_t(e) + 1], 0.0f);  // outer side of the face (local y = normal)
    EXPECT_NEAR(scaled_sigmoid(a.scale_logit[3 * size_t(e)], 0.1f), 0.05f / 1.6f, 1e-6);
    spread += a.offset[3 * size_t(e)] * a.offset[3 * size_t(e)];
  }
  // Offsets ~ N(0, 0.5 * 0.05) along x: the sample standard deviation is close to 0.025.
  EXPECT_NEAR(std::sqrt(spread / 400), 0.025, 0.005);
  GaussianParams c = g;
  apply_densify(c, plan, 0.1f, 0.5, 1.6, 8);
  EXPECT_NE(c.offset, a.offset);
}

TEST(GaussianParams, SelectAndAdamReindexStayAligned) {
  GaussianParams g = init_one_per_face(5, 0.02f, 0.5f, 0.9f, 0.1f);
  for (int i = 0; i < 5; ++i) g.opacity_logit[size_t(i)] = float(i);
  Adam adam;
  const int go = adam.add_group("opacity", 5, 0.1);
  std::vector<float> grad = {1, 2, 3, 4, 5};
  adam.step(go, g.opacity_logit.data(), grad.data());
  const std::vector<float> m = adam.first_moment(go);
  std::vector<uint8_t> keep = {1, 0, 1, 0, 1};
  const std::vector<int64_t> idx = indices_where(keep);
  EXPECT_EQ(idx, (std::vector<int64_t>{0, 2, 4}));
  const GaussianParams before = g;
  select(g, idx);
  adam.reindex(go, idx);
  ASSERT_EQ(g.size(), 3);
  for (int e = 0; e < 3; ++e) {
    EXPECT_EQ(g.opacity_logit[size_t(e)], before.opacity_logit[size_t(idx[size_t(e)])]);
    EXPECT_EQ(adam.first_moment(go)[size_t(e)], m[size_t(idx[size_t(e)])]);
  }
  EXPECT_THROW(select(g, {5}), Error);
}

TEST(GaussianParams, CounterRandomNumbersAreStableAndSpread) {
  EXPECT_EQ(hash64(1, 2, 3), hash64(1, 2, 3));
  EXPECT_NE(hash64(1, 2, 3), hash64(1, 2, 4));
  EXPECT_NE(hash64(1, 2, 3), hash64(2, 2, 3));
  double s = 0, s2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double u = uniform01(5, 1, uint64_t(i));
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    const double z = normal01(5, 2, uint64_t(i));
    ASSERT_TRUE(std::isfinite(z));
    s += z;
    s2 += z * z;
  }
  EXPECT_NEAR(s / n, 0.0, 0.03);
  EXPECT_NEAR(s2 / n, 1.0, 0.05);
}

}  // namespace
}  // namespace haha
