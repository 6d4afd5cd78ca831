// Small vector / matrix / quaternion maths, templated on the scalar so the same code
// runs in float (production) and double (finite-difference gradient tests), on host and
// CUDA device. Conventions:
//   - Mat3 is row-major: m(r, c) = m.a[r][c]; Mat3 * Vec3 multiplies a column vector.
//   - Quat stores (w, x, y, z); unit quaternions represent rotations.
//   - Axis-angle vectors: direction = axis, length = angle in radians.
#pragma once

#include <cmath>

#include "core/hd.h"

namespace haha {

template <class T>
struct Vec2 {
  T x{}, y{};
  Vec2() = default;
  HAHA_HD Vec2(T x_, T y_) : x(x_), y(y_) {}
  HAHA_HD T& operator[](int i) { return i == 0 ? x : y; }
  HAHA_HD const T& operator[](int i) const { return i == 0 ? x : y; }
};

template <class T>
struct Vec3 {
  T x{}, y{}, z{};
  Vec3() = default;
  HAHA_HD Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  HAHA_HD explicit Vec3(T s) : x(s), y(s), z(s) {}
  template <class U>
  HAHA_HD explicit Vec3(const Vec3<U>& o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}
  HAHA_HD T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  HAHA_HD const T& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  HAHA_HD static Vec3 load(const T* p) { return {p[0], p[1], p[2]}; }
  HAHA_HD void store(T* p) const { p[0] = x; p[1] = y; p[2] = z; }
};

template <class T>
struct Vec4 {
  T x{}, y{}, z{}, w{};
  Vec4() = default;
  HAHA_HD Vec4(T x_, T y_, T z_, T w_) : x(x_), y(y_), z(z_), w(w_) {}
};

// clang-format off
template <class T> HAHA_HD Vec2<T> operator+(Vec2<T> a, Vec2<T> b) { return {a.x + b.x, a.y + b.y}; }
template <class T> HAHA_HD Vec2<T> operator-(Vec2<T> a, Vec2<T> b) { return {a.x - b.x, a.y - b.y}; }
template <class T> HAHA_HD Vec2<T> operator*(T s, Vec2<T> a) { return {s * a.x, s * a.y}; }
template <class T> HAHA_HD Vec3<T> operator+(Vec3<T> a, Vec3<T> b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class T> HAHA_HD Vec3<T> operator-(Vec3<T> a, Vec3<T> b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class T> HAHA_HD Vec3<T> operator-(Vec3<T> a) { return {-a.x, -a.y, -a.z}; }
template <class T> HAHA_HD Vec3<T> operator*(T s, Vec3<T> a) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> HAHA_HD Vec3<T> operator*(Vec3<T> a, T s) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> HAHA_HD Vec3<T> operator/(Vec3<T> a, T s) { return {a.x / s, a.y / s, a.z / s}; }
template <class T> HAHA_HD Vec3<T> mul(Vec3<T> a, Vec3<T> b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
template <class T> HAHA_HD Vec3<T>& operator+=(Vec3<T>& a, Vec3<T> b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
template <class T> HAHA_HD Vec3<T>& operator-=(Vec3<T>& a, Vec3<T> b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
template <class T> HAHA_HD Vec3<T>& operator*=(Vec3<T>& a, T s) { a.x *= s; a.y *= s; a.z *= s; return a; }
template <class T> HAHA_HD T dot(Vec3<T> a, Vec3<T> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> HAHA_HD Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> HAHA_HD T norm2(Vec3<T> a) { return dot(a, a); }
template <class T> HAHA_HD T norm(Vec3<T> a) { return std::sqrt(dot(a, a)); }
// clang-format on

using Vec2f = Vec2<float>;
using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;

// Row-major 3x3 matrix.
template <class T>
struct Mat3 {
  T a[3][3]{};
  HAHA_HD T& operator()(int r, int c) { return a[r][c]; }
  HAHA_HD const T& operator()(int r, int c) const { return a[r][c]; }
  HAHA_HD static Mat3 identity() {
    Mat3 m;
    m.a[0][0] = m.a[1][1] = m.a[2][2] = T(1);
    return m;
  }
  HAHA_HD static Mat3 from_cols(Vec3<T> c0, Vec3<T> c1, Vec3<T> c2) {
    Mat3 m;
    for (int r = 0; r < 3; ++r) {
      m.a[r][0] = c0[r];
      m.a[r][1] = c1[r];
      m.a[r][2] = c2[r];
    }
    return m;
  }
  HAHA_HD Vec3<T> col(int c) const { return {a[0][c], a[1][c], a[2][c]}; }
  HAHA_HD Vec3<T> row(int r) const { return {a[r][0], a[r][1], a[r][2]}; }
  HAHA_HD static Mat3 load(const T* p) {  // 9 values, row-major
    Mat3 m;
    for (int i = 0; i < 9; ++i) m.a[i / 3][i % 3] = p[i];
    return m;
  }
  HAHA_HD void store(T* p) const {
    for (int i = 0; i < 9; ++i) p[i] = a[i / 3][i % 3];
  }
};

template <class T>
HAHA_HD Vec3<T> operator*(const Mat3<T>& m, Vec3<T> v) {
  return {m.a[0][0] * v.x + m.a[0][1] * v.y + m.a[0][2] * v.z,
          m.a[1][0] * v.x + m.a[1][1] * v.y + m.a[1][2] * v.z,
          m.a[2][0] * v.x + m.a[2][1] * v.y + m.a[2][2] * v.z};
}
template <class T>
HAHA_HD Mat3<T> operator*(const Mat3<T>& m, const Mat3<T>& n) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = m.a[i][0] * n.a[0][j] + m.a[i][1] * n.a[1][j] + m.a[i][2] * n.a[2][j];
  return r;
}
template <class T>
HAHA_HD Mat3<T> operator+(const Mat3<T>& m, const Mat3<T>& n) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = m.a[i][j] + n.a[i][j];
  return r;
}
template <class T>
HAHA_HD Mat3<T> operator*(T s, const Mat3<T>& m) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = s * m.a[i][j];
  return r;
}
template <class T>
HAHA_HD Mat3<T> transpose(const Mat3<T>& m) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = m.a[j][i];
  return r;
}
template <class T>
HAHA_HD Mat3<T> outer(Vec3<T> u, Vec3<T> v) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = u[i] * v[j];
  return r;
}
template <class T>
HAHA_HD Mat3<T> skew(Vec3<T> v) {  // skew(v) * u == cross(v, u)
  Mat3<T> r;
  r.a[0][1] = -v.z; r.a[0][2] = v.y;
  r.a[1][0] = v.z;  r.a[1][2] = -v.x;
  r.a[2][0] = -v.y; r.a[2][1] = v.x;
  return r;
}

using Mat3f = Mat3<float>;
using Mat3d = Mat3<double>;

// Rigid transform x -> R x + t.
template <class T>
struct Rigid {
  Mat3<T> R = Mat3<T>::identity();
  Vec3<T> t{};
  HAHA_HD Vec3<T> apply(Vec3<T> x) const { return R * x + t; }
};
template <class T>
HAHA_HD Rigid<T> operator*(const Rigid<T>& a, const Rigid<T>& b) {
  return {a.R * b.R, a.R * b.t + a.t};
}

// Quaternion (w, x, y, z).
template <class T>
struct Quat {
  T w{1}, x{}, y{}, z{};
  Quat() = default;
  HAHA_HD Quat(T w_, T x_, T y_, T z_) : w(w_), x(x_), y(y_), z(z_) {}
  HAHA_HD static Quat load(const T* p) { return {p[0], p[1], p[2], p[3]}; }
  HAHA_HD void store(T* p) const { p[0] = w; p[1] = x; p[2] = y; p[3] = z; }
};
template <class T>
HAHA_HD Quat<T> operator*(Quat<T> a, Quat<T> b) {  // Hamilton product
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
          a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
          a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
template <class T>
HAHA_HD T qnorm2(Quat<T> q) { return q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z; }

// Rotation matrix of a unit quaternion.
template <class T>
HAHA_HD Mat3<T> quat_to_mat(Quat<T> q) {
  const T w = q.w, x = q.x, y = q.y, z = q.z;
  Mat3<T> m;
  m.a[0][0] = 1 - 2 * (y * y + z * z); m.a[0][1] = 2 * (x * y - w * z);     m.a[0][2] = 2 * (x * z + w * y);
  m.a[1][0] = 2 * (x * y + w * z);     m.a[1][1] = 1 - 2 * (x * x + z * z); m.a[1][2] = 2 * (y * z - w * x);
  m.a[2][0] = 2 * (x * z - w * y);     m.a[2][1] = 2 * (y * z + w * x);     m.a[2][2] = 1 - 2 * (x * x + y * y);
  return m;
}

// Quaternion of a rotation matrix (Shepperd's method: picks the largest pivot so it is
// stable for every rotation, including angles near pi). Result has w >= 0.
template <class T>
HAHA_HD Quat<T> mat_to_quat(const Mat3<T>& m) {
  const T tr = m.a[0][0] + m.a[1][1] + m.a[2][2];
  Quat<T> q;
  if (tr > m.a[0][0] && tr > m.a[1][1] && tr > m.a[2][2]) {
    T s = std::sqrt(tr + 1) * 2;
    q = {s / 4, (m.a[2][1] - m.a[1][2]) / s, (m.a[0][2] - m.a[2][0]) / s, (m.a[1][0] - m.a[0][1]) / s};
  } else if (m.a[0][0] > m.a[1][1] && m.a[0][0] > m.a[2][2]) {
    T s = std::sqrt(1 + m.a[0][0] - m.a[1][1] - m.a[2][2]) * 2;
    q = {(m.a[2][1] - m.a[1][2]) / s, s / 4, (m.a[0][1] + m.a[1][0]) / s, (m.a[0][2] + m.a[2][0]) / s};
  } else if (m.a[1][1] > m.a[2][2]) {
    T s = std::sqrt(1 + m.a[1][1] - m.a[0][0] - m.a[2][2]) * 2;
    q = {(m.a[0][2] - m.a[2][0]) / s, (m.a[0][1] + m.a[1][0]) / s, s / 4, (m.a[1][2] + m.a[2][1]) / s};
  } else {
    T s = std::sqrt(1 + m.a[2][2] - m.a[0][0] - m.a[1][1]) * 2;
    q = {(m.a[1][0] - m.a[0][1]) / s, (m.a[0][2] + m.a[2][0]) / s, (m.a[1][2] + m.a[2][1]) / s, s / 4};
  }
  if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
  return q;
}

template <class T>
HAHA_HD T clamp(T v, T lo, T hi) { return v < lo ? lo : (v > hi ? hi : v); }
template <class T>
HAHA_HD T sigmoid(T x) { return T(1) / (T(1) + std::exp(-x)); }

}  // namespace haha
