// Real spherical harmonics up to degree 3 for view-dependent colour, in the basis and sign
// convention of the reference 3DGS rasterizer (so .ply scenes trained there render the
// same here). Coefficients are stored coefficient-major: sh[k * 3 + c] is coefficient k of
// channel c, k in [0, (deg + 1)^2). The colour of a Gaussian seen along the unit direction
// d (camera centre -> Gaussian) is  sum_k basis_k(d) * sh[k]  (+0.5 and the clamp at 0 are
// applied by the rasterizer, not here).
#pragma once

#include "core/hd.h"
#include "core/math.h"

namespace haha {

inline constexpr int kMaxShDegree = 3;
HAHA_HD constexpr int sh_coeff_count(int degree) { return (degree + 1) * (degree + 1); }

namespace sh_detail {
// Normalisation constants of the real SH basis.
inline constexpr double C0 = 0.28209479177387814;
inline constexpr double C1 = 0.4886025119029199;
inline constexpr double C2_0 = 1.0925484305920792, C2_1 = -1.0925484305920792, C2_2 = 0.31539156525252005,
                        C2_3 = -1.0925484305920792, C2_4 = 0.5462742152960396;
inline constexpr double C3_0 = -0.5900435899266435, C3_1 = 2.890611442640554, C3_2 = -0.4570457994644658,
                        C3_3 = 0.3731763325901154, C3_4 = -0.4570457994644658, C3_5 = 1.445305721320277,
                        C3_6 = -0.5900435899266435;
}  // namespace sh_detail

// Basis values b[k] at unit direction d, k < sh_coeff_count(degree).
template <class T>
HAHA_HD void sh_basis(int degree, Vec3<T> d, T* b) {
  using namespace sh_detail;
  const T x = d.x, y = d.y, z = d.z;
  b[0] = T(C0);
  if (degree < 1) return;
  b[1] = -T(C1) * y;
  b[2] = T(C1) * z;
  b[3] = -T(C1) * x;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  b[4] = T(C2_0) * x * y;
  b[5] = T(C2_1) * y * z;
  b[6] = T(C2_2) * (2 * zz - xx - yy);
  b[7] = T(C2_3) * x * z;
  b[8] = T(C2_4) * (xx - yy);
  if (degree < 3) return;
  b[9] = T(C3_0) * y * (3 * xx - yy);
  b[10] = T(C3_1) * x * y * z;
  b[11] = T(C3_2) * y * (4 * zz - xx - yy);
  b[12] = T(C3_3) * z * (2 * zz - 3 * xx - 3 * yy);
  b[13] = T(C3_4) * x * (4 * zz - xx - yy);
  b[14] = T(C3_5) * z * (xx - yy);
  b[15] = T(C3_6) * x * (xx - 3 * yy);
}

// Gradients of the basis: g[k] = d b[k] / d d (d treated as a free 3-vector).
template <class T>
HAHA_HD void sh_basis_grad(int degree, Vec3<T> d, Vec3<T>* g) {
  using namespace sh_detail;
  const T x = d.x, y = d.y, z = d.z;
  g[0] = Vec3<T>(0, 0, 0);
  if (degree < 1) return;
  g[1] = Vec3<T>(0, -T(C1), 0);
  g[2] = Vec3<T>(0, 0, T(C1));
  g[3] = Vec3<T>(-T(C1), 0, 0);
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  g[4] = Vec3<T>(T(C2_0) * y, T(C2_0) * x, 0);
  g[5] = Vec3<T>(0, T(C2_1) * z, T(C2_1) * y);
  g[6] = Vec3<T>(T(C2_2) * -2 * x, T(C2_2) * -2 * y, T(C2_2) * 4 * z);
  g[7] = Vec3<T>(T(C2_3) * z, 0, T(C2_3) * x);
  g[8] = Vec3<T>(T(C2_4) * 2 * x, T(C2_4) * -2 * y, 0);
  if (degree < 3) return;
  g[9] = Vec3<T>(T(C3_0) * 6 * x * y, T(C3_0) * (3 * xx - 3 * yy), 0);
  g[10] = Vec3<T>(T(C3_1) * y * z, T(C3_1) * x * z, T(C3_1) * x * y);
  g[11] = Vec3<T>(T(C3_2) * -2 * x * y, T(C3_2) * (4 * zz - xx - 3 * yy), T(C3_2) * 8 * y * z);
  g[12] = Vec3<T>(T(C3_3) * -6 * x * z, T(C3_3) * -6 * y * z, T(C3_3) * (6 * zz - 3 * xx - 3 * yy));
  g[13] = Vec3<T>(T(C3_4) * (4 * zz - 3 * xx - yy), T(C3_4) * -2 * x * y, T(C3_4) * 8 * x * z);
  g[14] = Vec3<T>(T(C3_5) * 2 * x * z, T(C3_5) * -2 * y * z, T(C3_5) * (xx - yy));
  g[15] = Vec3<T>(T(C3_6) * (3 * xx - 3 * yy), T(C3_6) * -6 * x * y, 0);
}

// sum_k basis_k(d) * sh[k] (per channel). `d` must be unit length.
template <class T>
HAHA_HD Vec3<T> eval_sh(int degree, const T* sh, Vec3<T> d) {
  T b[16];
  sh_basis(degree, d, b);
  Vec3<T> c(0, 0, 0);
  const int n = sh_coeff_count(degree);
  for (int k = 0; k < n; ++k) c += b[k] * Vec3<T>(sh[3 * k], sh[3 * k + 1], sh[3 * k + 2]);
  return c;
}

// Backward of eval_sh: d_sh[k*3+c] += b_k dL/dcolour_c; returns dL/dd (d as a free vector;
// the caller chains it through its normalisation).
template <class T>
HAHA_HD Vec3<T> eval_sh_backward(int degree, const T* sh, Vec3<T> d, Vec3<T> d_color, T* d_sh) {
  T b[16];
  Vec3<T> g[16];
  sh_basis(degree, d, b);
  sh_basis_grad(degree, d, g);
  Vec3<T> d_dir(0, 0, 0);
  const int n = sh_coeff_count(degree);
  for (int k = 0; k < n; ++k) {
    d_sh[3 * k] += b[k] * d_color.x;
    d_sh[3 * k + 1] += b[k] * d_color.y;
    d_sh[3 * k + 2] += b[k] * d_color.z;
    const T s = sh[3 * k] * d_color.x + sh[3 * k + 1] * d_color.y + sh[3 * k + 2] * d_color.z;
    d_dir += s * g[k];
  }
  return d_dir;
}

}  // namespace haha
