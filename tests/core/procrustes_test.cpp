// Similarity Procrustes (core/procrustes.h): properties that hold on every input. A rotated,
// scaled and moved copy aligns exactly (any rotation, including half turns); the error is
// invariant to a similarity of either set; a known residual is measured; bad sizes give NaN.
#include "core/procrustes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace haha {
namespace {

std::vector<Vec3d> random_points(int n, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<Vec3d> p;
  for (int i = 0; i < n; ++i) p.emplace_back(g(rng), g(rng), g(rng));
  return p;
}

Mat3<double> random_rotation(std::mt19937& rng, double angle) {
  std::normal_distribution<double> g(0.0, 1.0);
  Vec3d axis(g(rng), g(rng), g(rng));
  axis = axis / norm(axis);
  const double h = 0.5 * angle;
  return quat_to_mat(Quat<double>{std::cos(h), std::sin(h) * axis.x, std::sin(h) * axis.y, std::sin(h) * axis.z});
}

std::vector<Vec3d> similar(const std::vector<Vec3d>& a, const Mat3<double>& R, double s, Vec3d t) {
  std::vector<Vec3d> b;
  for (const Vec3d& p : a) b.push_back(s * (R * p) + t);
  return b;
}

TEST(Procrustes, SimilarCopyAlignsExactlyForAnyRotation) {
  std::mt19937 rng(3);
  const std::vector<Vec3d> a = random_points(22, rng);
  for (double angle : {0.0, 0.7, 2.5, 3.14159265358979}) {
    const std::vector<Vec3d> b = similar(a, random_rotation(rng, angle), 1.7, Vec3d(0.3, -2, 5));
    EXPECT_LT(procrustes_error(a, b), 1e-9) << angle;
  }
}

TEST(Procrustes, ErrorIsInvariantToASimilarityOfTheFittedSet) {
  std::mt19937 rng(4);
  const std::vector<Vec3d> a = random_points(22, rng);
  std::vector<Vec3d> b = a;
  std::normal_distribution<double> g(0.0, 0.02);
  for (Vec3d& p : b) p += Vec3d(g(rng), g(rng), g(rng));
  const double e = procrustes_error(a, b);
  EXPECT_GT(e, 0.005);
  EXPECT_NEAR(procrustes_error(a, similar(b, random_rotation(rng, 2.0), 0.4, Vec3d(1, 2, 3))), e, 1e-9);
}

TEST(Procrustes, KnownResidualAndBadSizes) {
  // Two points moved by 0.1 along z: the identity leaves a squared error of 0.02, the best
  // similarity (least squares) no more, so the mean distance is at most sqrt(0.02 / 4).
  const std::vector<Vec3d> a = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  const std::vector<Vec3d> b = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0.1}, {0, -1, -0.1}};
  const double e = procrustes_error(a, b);
  EXPECT_GT(e, 0.0);
  EXPECT_LE(e, std::sqrt(0.02 / 4) + 1e-12);
  EXPECT_TRUE(std::isnan(procrustes_error(a, {})));
  EXPECT_TRUE(std::isnan(procrustes_error({}, {})));
  EXPECT_EQ(procrustes_error({{1, 2, 3}}, {{4, 5, 6}}), 0.0);  // one point: only a translation
}

}  // namespace
}  // namespace haha
