// Adam: a hand-computed two-step trace, the log-linear position schedule, moments that
// follow densification / pruning, and the checkpoint state round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "core/error.h"
#include "support/expect_error.h"
#include "train/adam.h"

using namespace haha;
using haha::test::expect_error;

TEST(Adam, MatchesHandComputedTwoStepTrace) {
  // lr 0.1, b1 0.9, b2 0.999, eps 1e-8; p0 = 1, g1 = 0.5, g2 = -0.25.
  // Step 1: m = 0.05, v = 2.5e-4; m^ = 0.5, v^ = 0.25; p1 = 1 - 0.1 * 0.5 / (0.5 + 1e-8)
  //         = 0.900000002 (0.9 to float precision).
  // Step 2: m = 0.045 - 0.025 = 0.02, v = 2.4975e-4 + 6.25e-5 = 3.1225e-4;
  //         m^ = 0.02 / 0.19 = 0.10526316, v^ = 3.1225e-4 / 0.001999 = 0.15620310,
  //         sqrt = 0.39522538; p2 = 0.9 - 0.1 * 0.10526316 / 0.39522538 = 0.87336652.
  Adam adam(AdamConfig{0.9, 0.999, 1e-8});
  const int g = adam.add_group("x", 1, 0.1);
  float p = 1.0f, grad = 0.5f;
  adam.step(g, &p, &grad);
  EXPECT_NEAR(p, 0.9f, 1e-6f);
  EXPECT_NEAR(adam.first_moment(g)[0], 0.05f, 1e-8f);
  EXPECT_NEAR(adam.second_moment(g)[0], 2.5e-4f, 1e-10f);
  grad = -0.25f;
  adam.step(g, &p, &grad);
  EXPECT_NEAR(p, 0.87336652f, 2e-6f);
  EXPECT_NEAR(adam.first_moment(g)[0], 0.02f, 1e-8f);
  EXPECT_NEAR(adam.second_moment(g)[0], 3.1225e-4f, 1e-10f);
  EXPECT_EQ(adam.steps(g), 2);
}

TEST(Adam, DefaultsAreThe3dgsOnesAndGroupsAreIndependent) {
  Adam adam;
  EXPECT_EQ(adam.config().beta1, 0.9);
  EXPECT_EQ(adam.config().beta2, 0.999);
  EXPECT_EQ(adam.config().eps, 1e-15);
  const int a = adam.add_group("mu", 3, 1e-3, 3), b = adam.add_group("color", 3, 5e-3, 3);
  EXPECT_EQ(adam.group("color"), b);
  EXPECT_TRUE(adam.has_group("mu"));
  std::vector<float> pa = {0, 0, 0}, pb = {0, 0, 0}, g = {1, -2, 0};
  adam.step(a, pa.data(), g.data());
  adam.step(b, pb.data(), g.data());
  adam.step(b, pb.data(), g.data());
  // First step moves by lr against the gradient's sign; a zero gradient does not move.
  EXPECT_NEAR(pa[0], -1e-3f, 1e-9f);
  EXPECT_NEAR(pa[1], 1e-3f, 1e-9f);
  EXPECT_EQ(pa[2], 0.0f);
  EXPECT_NEAR(pb[0], -1e-2f, 1e-8f);  // two steps of 5e-3 with a constant gradient
  EXPECT_EQ(adam.steps(a), 1);
  EXPECT_EQ(adam.steps(b), 2);
  adam.set_lr(a, 0.5);
  EXPECT_EQ(adam.lr(a), 0.5);
  expect_error([&] { adam.add_group("mu", 3, 1.0); }, "mu", "twice");
  expect_error([&] { adam.add_group("q", 5, 1.0, 4); }, "q", "multiple");
  expect_error([&] { (void)adam.group("nope"); }, "nope");
}

TEST(Adam, LogLinearScheduleEndpoints) {
  const LogLinearLr s{1.6e-4, 1.6e-6, 3000};
  EXPECT_NEAR(s(0), 1.6e-4, 1e-18);
  EXPECT_NEAR(s(3000), 1.6e-6, 1e-20);
  EXPECT_NEAR(s(1500), 1.6e-5, 1e-18);  // log-linear: the midpoint is the geometric mean
  EXPECT_NEAR(s(10000), 1.6e-6, 1e-20);
  EXPECT_EQ(s(-1), 0.0);
  for (int64_t t = 1; t <= 3000; t += 37) EXPECT_LT(s(t), s(t - 1));
  EXPECT_NEAR(s(1000) / s(0), s(2000) / s(1000), 1e-12);  // constant ratio per step
  const LogLinearLr warm{1e-2, 1e-4, 100, 10, 0.01};
  EXPECT_NEAR(warm(0), 1e-4, 1e-18);  // delay_mult * lr_init
  EXPECT_NEAR(warm(10), 1e-2 * std::pow(1e-2, 0.1), 1e-15);
  EXPECT_EQ((LogLinearLr{0, 0, 10})(5), 0.0);
}

TEST(Adam, ReindexKeepsMomentsAlignedThroughPruneAndClone) {
  // Element e of a stride-3 group gets gradient (e+1) * (1, -2, 3); after pruning element
  // 1 and cloning element 3 (fresh), every kept element must continue exactly as in a
  // run that was never reindexed.
  auto grad_of = [](const std::vector<int64_t>& ids, int step) {
    std::vector<float> g;
    for (int64_t id : ids)
      for (float c : {1.f, -2.f, 3.f}) g.push_back(float(id + 1) * c * (step % 2 ? 1.f : 0.5f));
    return g;
  };
  Adam ref, test;
  const int gr = ref.add_group("mu", 12, 0.01, 3), gt = test.add_group("mu", 12, 0.01, 3);
  std::vector<float> pref(12, 0.f), ptest(12, 0.f);
  std::vector<int64_t> ids_ref = {0, 1, 2, 3}, ids_test = ids_ref;
  for (int s = 0; s < 3; ++s) {
    auto g = grad_of(ids_ref, s);
    ref.step(gr, pref.data(), g.data());
    test.step(gt, ptest.data(), g.data());
  }
  // Densify/prune: keep 3, 0, 2 (reordered), clone 3 as new (-1 = fresh moments).
  const std::vector<int64_t> source = {3, 0, 2, -1};
  test.reindex(gt, source);
  ids_test = {3, 0, 2, 3};  // the clone starts at its parent's value
  std::vector<float> p2;
  for (int64_t s : ids_test)
    for (int c = 0; c < 3; ++c) p2.push_back(ptest[size_t(3 * s + c)]);
  ptest = p2;
  EXPECT_EQ(test.size(gt), 12);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(test.first_moment(gt)[size_t(c)], ref.first_moment(gr)[size_t(9 + c)]);
    EXPECT_EQ(test.second_moment(gt)[size_t(3 + c)], ref.second_moment(gr)[size_t(c)]);
    EXPECT_EQ(test.first_moment(gt)[size_t(9 + c)], 0.f);
  }
  for (int s = 3; s < 6; ++s) {
    auto g = grad_of(ids_ref, s);
    ref.step(gr, pref.data(), g.data());
    auto h = grad_of(ids_test, s);
    test.step(gt, ptest.data(), h.data());
  }
  for (int e = 0; e < 3; ++e)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(ptest[size_t(3 * e + c)], pref[size_t(3 * ids_test[size_t(e)] + c)]);
  // The clone, same start and gradients as its parent but fresh moments, moves apart.
  EXPECT_NE(ptest[9], ptest[0]);
  expect_error([&] { test.reindex(gt, {0, 4}); }, "mu", "out of range");
}

TEST(Adam, StateRoundTripContinuesIdentically) {
  Adam a;
  const int ga = a.add_group("mu", 6, 0.01, 3);
  const int gq = a.add_group("rot", 4, 0.005, 4);
  std::vector<float> pm = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}, pq = {1, 0, 0, 0};
  std::vector<float> gm = {0.3f, -0.1f, 0.2f, 0.0f, 1.0f, -1.0f}, gq4 = {0.1f, 0.2f, -0.3f, 0.4f};
  for (int s = 0; s < 4; ++s) {
    a.step(ga, pm.data(), gm.data());
    a.step(gq, pq.data(), gq4.data());
  }
  const auto state = a.state();
  EXPECT_EQ(state.at("adam.mu.step"), std::vector<float>{4.f});
  EXPECT_EQ(state.at("adam.rot.m").size(), 4u);
  // A fresh optimiser registered with any size takes the stored size and moments.
  Adam b;
  const int gb = b.add_group("mu", 0, 0.01, 3);
  b.add_group("rot", 0, 0.005, 4);
  b.load_state(state, "ckpt.npz");
  EXPECT_EQ(b.size(gb), 6);
  EXPECT_EQ(b.steps(gb), 4);
  auto pm2 = pm;
  a.step(ga, pm.data(), gm.data());
  b.step(gb, pm2.data(), gm.data());
  EXPECT_EQ(pm, pm2);
  // Errors name the checkpoint and the key; a failed load changes nothing.
  auto missing = state;
  missing.erase("adam.rot.v");
  Adam c;
  c.add_group("mu", 0, 0.01, 3);
  c.add_group("rot", 0, 0.005, 4);
  expect_error([&] { c.load_state(missing, "ckpt.npz"); }, "ckpt.npz", "adam.rot.v: missing");
  EXPECT_EQ(c.size(0), 0);
  auto bad_stride = state;
  bad_stride["adam.mu.stride"] = {4.f};
  expect_error([&] { c.load_state(bad_stride, "ckpt.npz"); }, "ckpt.npz", "adam.mu.stride");
  auto bad_size = state;
  bad_size["adam.mu.v"].push_back(0.f);
  expect_error([&] { c.load_state(bad_size, "ckpt.npz"); }, "adam.mu.v");
  auto bad_step = state;
  bad_step["adam.mu.step"] = {2.5f};
  expect_error([&] { c.load_state(bad_step, "ckpt.npz"); }, "adam.mu.step");
}
