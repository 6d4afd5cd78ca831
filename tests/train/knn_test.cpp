// Uniform-grid KNN (train/knn.h) against brute force (exact indices, same tie rule) on
// volume, surface and degenerate clouds, and against nanoflann's k-d tree (distances)
// where libnanoflann-dev is installed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "train/knn.h"

#if __has_include(<nanoflann.hpp>)
#include <nanoflann.hpp>
#define HAHA_TEST_HAS_NANOFLANN 1
#endif

using namespace haha;

namespace {

// k nearest others of each point by (squared distance, index), same float arithmetic.
std::vector<int32_t> brute_force(const std::vector<float>& p, int k) {
  const int64_t n = int64_t(p.size() / 3);
  std::vector<int32_t> out(size_t(n * k), -1);
  std::vector<std::pair<float, int32_t>> c;
  for (int64_t i = 0; i < n; ++i) {
    c.clear();
    for (int64_t j = 0; j < n; ++j) {
      if (j == i) continue;
      const float dx = p[3 * j] - p[3 * i], dy = p[3 * j + 1] - p[3 * i + 1], dz = p[3 * j + 2] - p[3 * i + 2];
      c.emplace_back(dx * dx + dy * dy + dz * dz, int32_t(j));
    }
    std::sort(c.begin(), c.end());
    for (int t = 0; t < k && t < int(c.size()); ++t) out[size_t(i * k + t)] = c[size_t(t)].second;
  }
  return out;
}

void expect_same_as_brute_force(const std::vector<float>& p, int k, const char* what) {
  const int64_t n = int64_t(p.size() / 3);
  std::vector<int32_t> got(size_t(n * k));
  std::vector<float> d2(size_t(n * k));
  knn_search(p.data(), n, k, got.data(), d2.data());
  EXPECT_EQ(got, brute_force(p, k)) << what;
  for (int64_t i = 0; i < n; ++i)
    for (int t = 1; t < k; ++t) EXPECT_LE(d2[size_t(i * k + t - 1)], d2[size_t(i * k + t)]) << what;
}

std::vector<float> uniform_cloud(int n, unsigned seed, float sx = 1, float sy = 1, float sz = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> p(size_t(3 * n));
  for (int i = 0; i < n; ++i) {
    p[size_t(3 * i)] = sx * u(rng);
    p[size_t(3 * i + 1)] = sy * u(rng);
    p[size_t(3 * i + 2)] = sz * u(rng);
  }
  return p;
}

// Points on an ellipsoid shell (like Gaussians on a body surface) plus a dense cluster.
std::vector<float> surface_cloud(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  std::vector<float> p(size_t(3 * n));
  for (int i = 0; i < n; ++i) {
    float v[3] = {g(rng), g(rng), g(rng)};
    const float r = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const float s = i % 10 == 0 ? 0.01f : 1.0f;  // every 10th point in a tiny ball
    p[size_t(3 * i)] = 0.3f * s * v[0] / r;
    p[size_t(3 * i + 1)] = 0.9f * s * v[1] / r;
    p[size_t(3 * i + 2)] = 0.15f * s * v[2] / r;
  }
  return p;
}

}  // namespace

TEST(Knn, MatchesBruteForceOnVolumeAndSurfaceClouds) {
  expect_same_as_brute_force(uniform_cloud(1500, 1), 3, "uniform");
  expect_same_as_brute_force(uniform_cloud(800, 2), 8, "uniform k=8");
  expect_same_as_brute_force(uniform_cloud(1000, 3, 1.f, 1.f, 0.f), 2, "planar");
  expect_same_as_brute_force(uniform_cloud(700, 4, 5.f, 0.f, 0.f), 4, "collinear");
  expect_same_as_brute_force(surface_cloud(2000, 5), 2, "surface + cluster");
}

TEST(Knn, DegenerateCloudsHaveDefinedResults) {
  // All points equal: every distance is 0, so the tie rule picks the lowest indices.
  std::vector<float> same(3 * 50, 0.25f);
  expect_same_as_brute_force(same, 3, "all equal");
  std::vector<int32_t> idx(3 * 50);
  knn_search(same.data(), 50, 3, idx.data());
  EXPECT_EQ((std::vector<int32_t>{idx[0], idx[1], idx[2]}), (std::vector<int32_t>{1, 2, 3}));
  // Duplicated pairs and a lattice (many exact ties).
  std::vector<float> lattice;
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 5; ++y)
      for (int z = 0; z < 4; ++z)
        for (int dup = 0; dup < 2; ++dup) lattice.insert(lattice.end(), {0.1f * x, 0.1f * y, 0.1f * z});
  expect_same_as_brute_force(lattice, 6, "lattice with duplicates");
  // Fewer points than k: padded with -1 and +inf.
  std::vector<float> two = {0, 0, 0, 1, 0, 0};
  std::vector<int32_t> out(2 * 3);
  std::vector<float> d2(2 * 3);
  knn_search(two.data(), 2, 3, out.data(), d2.data());
  EXPECT_EQ(out, (std::vector<int32_t>{1, -1, -1, 0, -1, -1}));
  EXPECT_EQ(d2[0], 1.0f);
  EXPECT_EQ(d2[1], std::numeric_limits<float>::infinity());
  std::vector<float> one = {3, 4, 5};
  std::vector<int32_t> o1(2);
  knn_search(one.data(), 1, 2, o1.data());
  EXPECT_EQ(o1, (std::vector<int32_t>{-1, -1}));
}

TEST(Knn, SetsStartWithThePointItself) {
  const auto p = uniform_cloud(300, 6);
  std::vector<int32_t> sets(300 * 3), others(300 * 2);
  knn_sets(p.data(), 300, 3, sets.data());
  knn_search(p.data(), 300, 2, others.data());
  for (int i = 0; i < 300; ++i) {
    EXPECT_EQ(sets[size_t(3 * i)], i);
    EXPECT_EQ(sets[size_t(3 * i + 1)], others[size_t(2 * i)]);
    EXPECT_EQ(sets[size_t(3 * i + 2)], others[size_t(2 * i + 1)]);
  }
  std::vector<int32_t> self_only(300);
  knn_sets(p.data(), 300, 1, self_only.data());
  for (int i = 0; i < 300; ++i) EXPECT_EQ(self_only[size_t(i)], i);
}

#ifdef HAHA_TEST_HAS_NANOFLANN
namespace {
struct Cloud {
  const std::vector<float>& p;
  size_t kdtree_get_point_count() const { return p.size() / 3; }
  float kdtree_get_pt(size_t i, size_t d) const { return p[3 * i + d]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
}  // namespace

TEST(Knn, AgreesWithNanoflann) {
  const auto p = surface_cloud(5000, 7);
  const int64_t n = 5000;
  const int k = 3;
  std::vector<int32_t> idx(size_t(n * k));
  std::vector<float> d2(size_t(n * k));
  knn_search(p.data(), n, k, idx.data(), d2.data());
  Cloud cloud{p};
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, uint32_t>;
  Tree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  tree.buildIndex();
  uint32_t ni[k + 1];
  float nd[k + 1];
  for (int64_t i = 0; i < n; ++i) {
    ASSERT_EQ(tree.knnSearch(&p[size_t(3 * i)], k + 1, ni, nd), size_t(k + 1));
    ASSERT_EQ(nd[0], 0.0f);  // the point itself (the cloud has no duplicates)
    for (int t = 0; t < k; ++t) EXPECT_NEAR(d2[size_t(i * k + t)], nd[t + 1], 1e-6f * (1 + nd[t + 1]));
  }
}
#endif
