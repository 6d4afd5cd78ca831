// Axis-angle <-> rotation matrix / quaternion, with the hand-written backward of Rodrigues'
// formula beside its forward. HAHA_HD: the same code runs on CPU and CUDA, in float and
// double.
//
// Rodrigues with w = axis * angle, K = skew(w) (NOT normalised), s = |w|^2:
//   R(w) = I + a(s) K + b(s) K^2,   a = sin(t)/t,  b = (1 - cos t)/t^2,  t = sqrt(s).
// Writing a, b as functions of s (not t) keeps every expression polynomial near 0: below
// kRodriguesTaylorS the Taylor series is used, so R and dR/dw are exact at w = 0 (no
// division by the angle anywhere). sin/cos make R 2*pi periodic in the angle; R is an
// entire function of w, so angles near pi need no special case either.
#pragma once

#include <cmath>

#include "core/hd.h"
#include "core/math.h"

namespace haha {

// Below this squared angle (rad^2) the series replace the closed forms. At s = 0.1 the
// truncation error of the series below is < 1e-13 relative and the closed forms lose
// < 1e-14 to cancellation (double), so the switch is seamless in both precisions.
constexpr double kRodriguesTaylorS = 0.1;

// a(s), b(s) and their derivatives a'(s), b'(s) with respect to s = t^2.
template <class T>
struct RodriguesCoeffs {
  T a, b, da, db;
};

template <class T>
HAHA_HD RodriguesCoeffs<T> rodrigues_coeffs(T s) {
  RodriguesCoeffs<T> c;
  if (s < T(kRodriguesTaylorS)) {
    // a = sum (-s)^k/(2k+1)!, b = sum (-s)^k/(2k+2)!; six terms each (Horner).
    c.a = T(1) + s * (T(-1.0 / 6) + s * (T(1.0 / 120) + s * (T(-1.0 / 5040) + s * (T(1.0 / 362880) + s * T(-1.0 / 39916800)))));
    c.b = T(0.5) + s * (T(-1.0 / 24) + s * (T(1.0 / 720) + s * (T(-1.0 / 40320) + s * (T(1.0 / 3628800) + s * T(-1.0 / 479001600)))));
    c.da = T(-1.0 / 6) + s * (T(2.0 / 120) + s * (T(-3.0 / 5040) + s * (T(4.0 / 362880) + s * (T(-5.0 / 39916800) + s * T(6.0 / 6227020800)))));
    c.db = T(-1.0 / 24) + s * (T(2.0 / 720) + s * (T(-3.0 / 40320) + s * (T(4.0 / 3628800) + s * (T(-5.0 / 479001600) + s * T(6.0 / 87178291200)))));
  } else {
    const T t = std::sqrt(s);
    const T sn = std::sin(t), cs = std::cos(t);
    const T half = std::sin(t / 2);
    const T one_minus_cos = T(2) * half * half;  // 1 - cos t without cancellation
    c.a = sn / t;
    c.b = one_minus_cos / s;
    // d/ds = (1/(2t)) d/dt
    c.da = (t * cs - sn) / (T(2) * s * t);
    c.db = (t * sn - T(2) * one_minus_cos) / (T(2) * s * s);
  }
  return c;
}

// Axis-angle -> rotation matrix.
template <class T>
HAHA_HD Mat3<T> rodrigues(Vec3<T> w) {
  const RodriguesCoeffs<T> c = rodrigues_coeffs(norm2(w));
  const Mat3<T> K = skew(w);
  const Mat3<T> K2 = K * K;
  Mat3<T> R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R.a[i][j] = (i == j ? T(1) : T(0)) + c.a * K.a[i][j] + c.b * K2.a[i][j];
  return R;
}

// vee of the antisymmetric part times 2: (M21 - M12, M02 - M20, M10 - M01), so that
// <M, skew(v)> (Frobenius) = dot(v, vee_asym(M)).
template <class T>
HAHA_HD Vec3<T> vee_asym(const Mat3<T>& m) {
  return {m.a[2][1] - m.a[1][2], m.a[0][2] - m.a[2][0], m.a[1][0] - m.a[0][1]};
}

template <class T>
HAHA_HD T frob(const Mat3<T>& m, const Mat3<T>& n) {
  T s = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += m.a[i][j] * n.a[i][j];
  return s;
}

// Backward of rodrigues(): given G = dL/dR, returns dL/dw.
//   dR/dw_i = 2 w_i (a' K + b' K^2) + a E_i + b (E_i K + K E_i),  E_i = skew(e_i)
//   <G, E_i K> = <G K^T, E_i>,  <G, K E_i> = <K^T G, E_i>.
template <class T>
HAHA_HD Vec3<T> rodrigues_backward(Vec3<T> w, const Mat3<T>& G) {
  const RodriguesCoeffs<T> c = rodrigues_coeffs(norm2(w));
  const Mat3<T> K = skew(w);
  const Mat3<T> Kt = transpose(K);
  const Mat3<T> K2 = K * K;
  const T radial = T(2) * (c.da * frob(G, K) + c.db * frob(G, K2));
  const Vec3<T> g1 = vee_asym(G);
  const Vec3<T> g2 = vee_asym(G * Kt + Kt * G);
  return radial * w + c.a * g1 + c.b * g2;
}

// Axis-angle -> unit quaternion (w, x, y, z); q = (cos(t/2), sin(t/2)/t * w), series near 0.
template <class T>
HAHA_HD Quat<T> axis_angle_to_quat(Vec3<T> w) {
  const T s = norm2(w);
  T half_sinc;  // sin(t/2)/t
  T c;
  if (s < T(kRodriguesTaylorS)) {
    half_sinc = T(0.5) + s * (T(-1.0 / 48) + s * (T(1.0 / 3840) + s * (T(-1.0 / 645120) + s * T(1.0 / 185794560))));
    c = T(1) + s * (T(-1.0 / 8) + s * (T(1.0 / 384) + s * (T(-1.0 / 46080) + s * T(1.0 / 10321920))));
  } else {
    const T t = std::sqrt(s);
    half_sinc = std::sin(t / 2) / t;
    c = std::cos(t / 2);
  }
  return {c, half_sinc * w.x, half_sinc * w.y, half_sinc * w.z};
}

// Unit quaternion -> axis-angle with angle in [0, pi] (q and -q give the same result).
// Uses atan2, which is accurate at every angle, including near 0 and near pi.
template <class T>
HAHA_HD Vec3<T> quat_to_axis_angle(Quat<T> q) {
  if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
  const Vec3<T> v{q.x, q.y, q.z};
  const T n2 = norm2(v);
  const T n = std::sqrt(n2);
  T scale;  // angle / |v|
  if (n2 < T(1e-8) * q.w * q.w) {
    // angle = 2 atan(n / w) = 2 (n/w) (1 - (n/w)^2 / 3 + ...); error < 1e-16 relative here
    const T r2 = n2 / (q.w * q.w);
    scale = T(2) / q.w * (T(1) - r2 / T(3));
  } else {
    scale = T(2) * std::atan2(n, q.w) / n;
  }
  return scale * v;
}

// Rotation matrix -> axis-angle (angle in [0, pi]); stable near pi through Shepperd's
// quaternion extraction.
template <class T>
HAHA_HD Vec3<T> matrix_to_axis_angle(const Mat3<T>& R) {
  return quat_to_axis_angle(mat_to_quat(R));
}

// Backward of mat_to_quat (core/math.h) for dL/dq: follows the same branch (Shepperd
// pivot) and the same final sign flip as the forward, so it is that function's exact
// derivative. For a rotation-valued R(x) every branch gives the same chain-rule result
// (they differ only off the rotation manifold).
template <class T>
HAHA_HD Mat3<T> mat_to_quat_backward(const Mat3<T>& m, Quat<T> dq) {
  const T tr = m.a[0][0] + m.a[1][1] + m.a[2][2];
  Mat3<T> g;
  // Each branch: slot `branch` of q is s/4, the other three are u_i / s, s = 2 sqrt(arg),
  // u_i a sum or difference of two off-diagonal entries.
  T dqv[4] = {dq.w, dq.x, dq.y, dq.z};
  const Quat<T> q = mat_to_quat(m);
  int branch;
  T arg;
  if (tr > m.a[0][0] && tr > m.a[1][1] && tr > m.a[2][2]) {
    branch = 0; arg = tr + 1;
  } else if (m.a[0][0] > m.a[1][1] && m.a[0][0] > m.a[2][2]) {
    branch = 1; arg = 1 + m.a[0][0] - m.a[1][1] - m.a[2][2];
  } else if (m.a[1][1] > m.a[2][2]) {
    branch = 2; arg = 1 + m.a[1][1] - m.a[0][0] - m.a[2][2];
  } else {
    branch = 3; arg = 1 + m.a[2][2] - m.a[0][0] - m.a[1][1];
  }
  const T s = std::sqrt(arg) * 2;
  // Unflipped q has slot `branch` = s/4 > 0; the flip happened iff that slot's sign in
  // the returned q is negative.
  const T slot[4] = {q.w, q.x, q.y, q.z};
  if (slot[branch] < 0)
    for (int i = 0; i < 4; ++i) dqv[i] = -dqv[i];
  // Numerators u_i (slot i != branch) as +/- pairs of matrix entries:
  //   pair (w,x): m21 - m12   (w,y): m02 - m20   (w,z): m10 - m01
  //   pair (x,y): m01 + m10   (x,z): m02 + m20   (y,z): m12 + m21
  struct Pair { int r0, c0, r1, c1; T sign1; };
  auto pair_of = [](int i, int j) -> Pair {
    if (i > j) { int t = i; i = j; j = t; }
    if (i == 0 && j == 1) return {2, 1, 1, 2, T(-1)};
    if (i == 0 && j == 2) return {0, 2, 2, 0, T(-1)};
    if (i == 0 && j == 3) return {1, 0, 0, 1, T(-1)};
    if (i == 1 && j == 2) return {0, 1, 1, 0, T(1)};
    if (i == 1 && j == 3) return {0, 2, 2, 0, T(1)};
    return {1, 2, 2, 1, T(1)};
  };
  T ds = dqv[branch] / 4;
  for (int i = 0; i < 4; ++i) {
    if (i == branch) continue;
    const Pair p = pair_of(branch, i);
    const T u = m.a[p.r0][p.c0] + p.sign1 * m.a[p.r1][p.c1];
    ds -= dqv[i] * u / (s * s);
    g.a[p.r0][p.c0] += dqv[i] / s;
    g.a[p.r1][p.c1] += p.sign1 * dqv[i] / s;
  }
  // s = 2 sqrt(arg): ds/darg = 2 / s; arg's diagonal signs per branch.
  const T da = ds * 2 / s;
  for (int d = 0; d < 3; ++d) {
    T sign;
    if (branch == 0) sign = T(1);
    else sign = (d == branch - 1) ? T(1) : T(-1);
    g.a[d][d] += sign * da;
  }
  return g;
}

}  // namespace haha
