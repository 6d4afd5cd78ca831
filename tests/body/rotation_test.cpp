// Rodrigues forward/backward, axis-angle <-> quaternion / matrix, mat_to_quat backward.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "body/rotation.h"

namespace haha {
namespace {

constexpr double kPi = 3.14159265358979323846;

double max_abs_diff(const Mat3d& a, const Mat3d& b) {
  double m = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m = std::max(m, std::fabs(a(i, j) - b(i, j)));
  return m;
}

// Reference in long double from the closed form (t > 0 only).
Mat3d rodrigues_reference(Vec3d w) {
  const long double t = std::sqrt((long double)(w.x * w.x + w.y * w.y + w.z * w.z));
  const long double k[3] = {w.x / t, w.y / t, w.z / t};
  const long double s = std::sin(t), c = std::cos(t);
  Mat3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      long double K = 0, K2 = k[i] * k[j] - (i == j ? 1.0L : 0.0L);
      if (i == 0 && j == 1) K = -k[2];
      if (i == 0 && j == 2) K = k[1];
      if (i == 1 && j == 0) K = k[2];
      if (i == 1 && j == 2) K = -k[0];
      if (i == 2 && j == 0) K = -k[1];
      if (i == 2 && j == 1) K = k[0];
      R(i, j) = double((i == j ? 1.0L : 0.0L) + s * K + (1 - c) * K2);
    }
  return R;
}

void expect_rotation(const Mat3d& R, double tol) {
  const Mat3d RtR = transpose(R) * R;
  EXPECT_LT(max_abs_diff(RtR, Mat3d::identity()), tol);
  const double det = R(0, 0) * (R(1, 1) * R(2, 2) - R(1, 2) * R(2, 1)) - R(0, 1) * (R(1, 0) * R(2, 2) - R(1, 2) * R(2, 0)) +
                     R(0, 2) * (R(1, 0) * R(2, 1) - R(1, 1) * R(2, 0));
  EXPECT_NEAR(det, 1.0, tol);
}

// Central-difference check of rodrigues_backward for a random dL/dR. Tolerance: 1e-7
// relative to the gradient's largest component (h = 1e-6, error O(h^2) + roundoff).
void check_rodrigues_gradient(Vec3d w, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Mat3d G;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G(i, j) = u(rng);
  const Vec3d g = rodrigues_backward(w, G);
  double scale = 1e-3;
  for (int i = 0; i < 3; ++i) scale = std::max(scale, std::fabs(g[i]));
  const double h = 1e-6;
  for (int i = 0; i < 3; ++i) {
    Vec3d wp = w, wm = w;
    wp[i] += h;
    wm[i] -= h;
    const double num = (frob(G, rodrigues(wp)) - frob(G, rodrigues(wm))) / (2 * h);
    EXPECT_NEAR(g[i], num, 1e-7 * scale) << "component " << i << " at w = (" << w.x << ", " << w.y << ", " << w.z << ")";
    EXPECT_TRUE(std::isfinite(g[i]));
  }
}

TEST(Rotation, RodriguesIsExactIdentityAtZero) {
  const Mat3d R = rodrigues(Vec3d(0, 0, 0));
  EXPECT_EQ(max_abs_diff(R, Mat3d::identity()), 0.0);
  const Mat3f Rf = rodrigues(Vec3f(0, 0, 0));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_EQ(Rf(i, j), i == j ? 1.0f : 0.0f);
}

TEST(Rotation, RodriguesMatchesLongDoubleReferenceAcrossTheSeriesSwitch) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  // Angles spanning the Taylor branch, the switch at sqrt(0.1), and large angles.
  for (double t : {1e-8, 1e-4, 0.1, 0.3, std::sqrt(kRodriguesTaylorS) * (1 - 1e-12), std::sqrt(kRodriguesTaylorS) * (1 + 1e-12),
                   0.5, 1.0, 2.0, kPi - 1e-6, kPi, kPi + 1e-6, 5.0, 2 * kPi - 1e-3, 20.0}) {
    Vec3d a(u(rng), u(rng), u(rng));
    a = a / norm(a);
    const Vec3d w = t * a;
    const Mat3d R = rodrigues(w);
    EXPECT_LT(max_abs_diff(R, rodrigues_reference(w)), 4e-16 * std::max(1.0, t)) << "t = " << t;
    expect_rotation(R, 1e-14);
  }
}

TEST(Rotation, RodriguesAgreesWithQuaternionPath) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-4, 4);
  for (int n = 0; n < 200; ++n) {
    const Vec3d w(u(rng), u(rng), u(rng));
    EXPECT_LT(max_abs_diff(rodrigues(w), quat_to_mat(axis_angle_to_quat(w))), 1e-14);
  }
}

TEST(Rotation, FullTurnEqualsNoTurn) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 50; ++n) {
    Vec3d a(u(rng), u(rng), u(rng));
    a = a / norm(a);
    const double t = 2.5 * u(rng);
    const Mat3d R0 = rodrigues(t * a);
    EXPECT_LT(max_abs_diff(R0, rodrigues((t + 2 * kPi) * a)), 1e-14);
    EXPECT_LT(max_abs_diff(R0, rodrigues((t - 4 * kPi) * a)), 1e-14);
  }
  EXPECT_LT(max_abs_diff(rodrigues(Vec3d(0, 2 * kPi, 0)), Mat3d::identity()), 1e-15);
  const Mat3f Rf = rodrigues(Vec3f(0, float(2 * kPi), 0));
  EXPECT_LT(std::fabs(Rf(0, 0) - 1.0f) + std::fabs(Rf(0, 2)), 1e-6f);
}

TEST(Rotation, RodriguesBackwardMatchesFiniteDifferences) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1, 1);
  uint32_t seed = 100;
  for (double t : {0.0, 1e-9, 1e-3, 0.2, std::sqrt(kRodriguesTaylorS), 0.7, 1.5, 3.0, kPi - 1e-7, kPi, kPi + 1e-7,
                   2 * kPi, 9.0}) {
    for (int rep = 0; rep < 3; ++rep) {
      Vec3d a(u(rng), u(rng), u(rng));
      a = a / norm(a);
      check_rodrigues_gradient(t * a, seed++);
    }
  }
}

TEST(Rotation, RodriguesBackwardAtZeroIsTheSkewProjection) {
  // dR/dw_i at 0 is skew(e_i), so dL/dw = vee_asym(G) exactly.
  Mat3d G;
  for (int i = 0; i < 9; ++i) G.a[i / 3][i % 3] = 0.1 * (i + 1) * (i % 2 ? -1 : 1);
  const Vec3d g = rodrigues_backward(Vec3d(0, 0, 0), G);
  const Vec3d want = vee_asym(G);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(g[i], want[i]);
}

TEST(Rotation, AxisAngleRoundTripsIncludingNearPi) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double t : {0.0, 1e-12, 1e-6, 0.3, 1.0, 2.0, 3.0, kPi - 1e-5, kPi - 1e-9}) {
    for (int rep = 0; rep < 5; ++rep) {
      Vec3d a(u(rng), u(rng), u(rng));
      a = a / norm(a);
      const Vec3d w = t * a;
      const Vec3d back = matrix_to_axis_angle(rodrigues(w));
      // Near pi the axis is recovered from the diagonal: error ~ sqrt(eps) / (pi - t)
      // is avoided by Shepperd's pivot, so the absolute error stays tiny.
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], w[i], 1e-9) << "t = " << t;
      const Vec3d bq = quat_to_axis_angle(axis_angle_to_quat(w));
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(bq[i], w[i], 1e-12) << "t = " << t;
    }
  }
  // Exactly pi: the sign of the axis is ambiguous; the rotation must be reproduced.
  const Vec3d w(kPi / std::sqrt(3.0), -kPi / std::sqrt(3.0), kPi / std::sqrt(3.0));
  const Mat3d R = rodrigues(w);
  EXPECT_LT(max_abs_diff(rodrigues(matrix_to_axis_angle(R)), R), 1e-12);
  EXPECT_NEAR(norm(matrix_to_axis_angle(R)), kPi, 1e-12);
}

TEST(Rotation, MatToQuatBackwardMatchesFiniteDifferencesOnEveryBranch) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  // Rotations whose Shepperd pivot is w, x, y, z in turn, perturbed off the manifold so
  // that the full 9-entry derivative is tested.
  // Negative axis components on the x / y / z pivots make the forward flip the sign.
  const Vec3d ws[] = {{0.2, -0.1, 0.3}, {2.8, 0.1, 0.2},  {0.1, 2.9, -0.3}, {-0.2, 0.3, 3.0},
                      {0, 0, 3.1},      {-2.8, 0.1, 0.2}, {0.1, -2.9, 0.3}, {0.2, 0.3, -3.0}};
  for (const Vec3d& w : ws) {
    Mat3d M = rodrigues(w);
    for (int i = 0; i < 9; ++i) M.a[i / 3][i % 3] += 0.01 * u(rng);
    const Quat<double> gq(u(rng), u(rng), u(rng), u(rng));
    const Mat3d g = mat_to_quat_backward(M, gq);
    auto L = [&](const Mat3d& m) {
      const Quat<double> q = mat_to_quat(m);
      return gq.w * q.w + gq.x * q.x + gq.y * q.y + gq.z * q.z;
    };
    const double h = 1e-6;
    for (int i = 0; i < 9; ++i) {
      Mat3d mp = M, mm = M;
      mp.a[i / 3][i % 3] += h;
      mm.a[i / 3][i % 3] -= h;
      EXPECT_NEAR(g.a[i / 3][i % 3], (L(mp) - L(mm)) / (2 * h), 1e-7) << "entry " << i;
    }
  }
}

}  // namespace
}  // namespace haha
