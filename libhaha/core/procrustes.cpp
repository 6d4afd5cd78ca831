// Umeyama's similarity (libhaha/core/procrustes.h): the rotation from Horn's quaternion (the
// top eigenvector of the 4x4 profile matrix, by power iteration on a shifted, positive
// definite copy), then the least-squares scale.
#include "core/procrustes.h"

#include <cmath>

namespace haha {

double procrustes_error(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  const size_t n = a.size();
  if (n == 0 || b.size() != n) return NAN;
  Vec3d ma(0, 0, 0), mb(0, 0, 0);
  for (size_t i = 0; i < n; ++i) ma += a[i], mb += b[i];
  ma = ma / double(n), mb = mb / double(n);
  double S[3][3] = {}, vb = 0;
  for (size_t i = 0; i < n; ++i) {
    const Vec3d pa = a[i] - ma, pb = b[i] - mb;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) S[r][c] += pb[r] * pa[c];
    vb += norm2(pb);
  }
  const double Sxx = S[0][0], Sxy = S[0][1], Sxz = S[0][2], Syx = S[1][0], Syy = S[1][1], Syz = S[1][2], Szx = S[2][0],
               Szy = S[2][1], Szz = S[2][2];
  double N[4][4] = {{Sxx + Syy + Szz, Syz - Szy, Szx - Sxz, Sxy - Syx},
                    {Syz - Szy, Sxx - Syy - Szz, Sxy + Syx, Szx + Sxz},
                    {Szx - Sxz, Sxy + Syx, -Sxx + Syy - Szz, Syz + Szy},
                    {Sxy - Syx, Szx + Sxz, Syz + Szy, -Sxx - Syy + Szz}};
  double shift = 0;
  for (auto& row : N)
    for (double x : row) shift += std::abs(x);
  for (int i = 0; i < 4; ++i) N[i][i] += shift;  // positive definite: power iteration finds the top one
  double q[4] = {1, 0.1, 0.01, 0.001};
  for (int it = 0; it < 2000; ++it) {
    double r[4] = {};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) r[i] += N[i][j] * q[j];
    const double l = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    if (!(l > 0)) break;  // all points coincide: identity
    for (int i = 0; i < 4; ++i) q[i] = r[i] / l;
  }
  const Mat3<double> R = quat_to_mat(Quat<double>{q[0], q[1], q[2], q[3]});
  double num = 0;
  for (size_t i = 0; i < n; ++i) num += dot(a[i] - ma, R * (b[i] - mb));
  const double s = vb > 0 ? num / vb : 1;
  double err = 0;
  for (size_t i = 0; i < n; ++i) err += norm((a[i] - ma) - s * (R * (b[i] - mb)));
  return err / double(n);
}

}  // namespace haha
