// Spherical harmonics for Gaussian colours (render/sh.h): the basis is orthonormal over the
// sphere (checks every constant), has the 3DGS sign convention, and its backward matches
// central finite differences in double (relative tolerance 1e-7).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "render/sh.h"

using namespace haha;

TEST(SphericalHarmonics, BasisIsOrthonormalOnTheSphere) {
  // Midpoint quadrature in (cos theta, phi); error ~2e-5 at this resolution.
  const int nt = 800, np = 64;  // uniform phi is exact for these trigonometric degrees
  double gram[16][16] = {};
  for (int i = 0; i < nt; ++i)
    for (int j = 0; j < np; ++j) {
      const double ct = -1 + (i + 0.5) * 2.0 / nt, st = std::sqrt(1 - ct * ct), ph = (j + 0.5) * 2 * M_PI / np;
      double b[16];
      sh_basis(3, Vec3<double>(st * std::cos(ph), st * std::sin(ph), ct), b);
      const double w = (2.0 / nt) * (2 * M_PI / np);
      for (int k = 0; k < 16; ++k)
        for (int l = 0; l < 16; ++l) gram[k][l] += w * b[k] * b[l];
    }
  for (int k = 0; k < 16; ++k)
    for (int l = 0; l < 16; ++l) EXPECT_NEAR(gram[k][l], k == l ? 1.0 : 0.0, 1e-4) << k << "," << l;
}

TEST(SphericalHarmonics, SignConventionOf3dgs) {
  // Degree 1 of the reference: -C1 y, C1 z, -C1 x.
  double b[16];
  sh_basis(3, Vec3<double>(1, 0, 0), b);
  EXPECT_LT(b[3], 0);
  EXPECT_NEAR(b[3], -0.4886025119029199, 1e-15);
  sh_basis(3, Vec3<double>(0, 1, 0), b);
  EXPECT_LT(b[1], 0);
  sh_basis(3, Vec3<double>(0, 0, 1), b);
  EXPECT_GT(b[2], 0);
  EXPECT_NEAR(b[6], 2 * 0.31539156525252005, 1e-15);
  EXPECT_NEAR(b[12], 2 * 0.3731763325901154, 1e-15);
  // Degree-0 only: colour = C0 * dc.
  const double sh0[3] = {1, 2, 3};
  const auto c = eval_sh(0, sh0, Vec3<double>(0.6, 0, 0.8));
  EXPECT_NEAR(c.y, 2 * 0.28209479177387814, 1e-15);
}

TEST(SphericalHarmonics, BackwardMatchesFiniteDifferences) {
  std::mt19937 rng(4);
  std::normal_distribution<double> N(0, 1);
  for (int deg = 0; deg <= 3; ++deg) {
    const int K = sh_coeff_count(deg);
    std::vector<double> sh(3 * K);
    for (auto& v : sh) v = N(rng);
    Vec3<double> d(N(rng), N(rng), N(rng));
    const Vec3<double> w(N(rng), N(rng), N(rng));  // loss = w . colour
    auto loss = [&] { return dot(w, eval_sh(deg, sh.data(), d)); };
    std::vector<double> dsh(3 * K, 0.0);
    const Vec3<double> dd = eval_sh_backward(deg, sh.data(), d, w, dsh.data());
    const double eps = 1e-6;
    for (int k = 0; k < 3 * K; ++k) {
      const double v = sh[size_t(k)];
      sh[size_t(k)] = v + eps;
      const double lp = loss();
      sh[size_t(k)] = v - eps;
      const double lm = loss();
      sh[size_t(k)] = v;
      const double fd = (lp - lm) / (2 * eps);
      EXPECT_NEAR(dsh[size_t(k)], fd, 1e-7 * std::max(1.0, std::abs(fd))) << "deg " << deg << " sh " << k;
    }
    for (int a = 0; a < 3; ++a) {
      const double v = d[a];
      d[a] = v + eps;
      const double lp = loss();
      d[a] = v - eps;
      const double lm = loss();
      d[a] = v;
      const double fd = (lp - lm) / (2 * eps);
      EXPECT_NEAR(dd[a], fd, 1e-7 * std::max(1.0, std::abs(fd))) << "deg " << deg << " dir " << a;
      if (deg > 0) {
        EXPECT_NE(dd[a], 0.0);
      }
    }
  }
}
