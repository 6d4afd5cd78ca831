// Per-Gaussian and per-pixel maths of the Gaussian rasterizer, forward and backward side
// by side, written once for CPU and CUDA (HAHA_HD) and templated on the scalar (float in
// production, double for finite-difference tests). The CPU launcher is gaussian_raster.cpp.
//
// Model (3DGS EWA splatting):
//   p      = R_cam mean + t_cam                      camera-space centre, depth z = p.z
//   Sigma  = M M^T, M = R(q / |q|) diag(s)           3D covariance
//   u, v   = clamp(p.x / p.z), clamp(p.y / p.z)      to kFovClamp times the image's
//                                                    half-extent in tan space (each side)
//   J      = [[fx/z, 0, -fx u/z], [0, fy/z, -fy v/z]]
//   cov2d  = (J R_cam) Sigma (J R_cam)^T + kDilation I
//   opac'  = opac                                  (plain)
//          = opac sqrt(det(cov2d - kDilation I) / det(cov2d))   (antialiased)
//   mean2d = (fx p.x/z + cx, fy p.y/z + cy)         (not clamped)
//   alpha(pixel) = min(kAlphaMax, opac' exp(-0.5 d^T cov2d^-1 d)), d = pixel - mean2d;
//   the pixel skips the Gaussian when alpha < kAlphaMin.
// Every clamp and threshold is a constant below, used by both passes.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/hd.h"
#include "core/math.h"
#include "core/camera.h"

namespace haha::gs {

inline constexpr int kTileSize = 16;
inline constexpr double kDilation = 0.3;              // low-pass filter added to cov2d (px^2)
inline constexpr double kAlphaMin = 1.0 / 255.0;      // smaller alphas are skipped
inline constexpr double kAlphaMax = 0.99;             // alpha clamp
inline constexpr double kTransmittanceMin = 1e-4;     // early stop: a pixel ends before T drops below
inline constexpr double kFovClamp = 1.3;              // Jacobian clamp (multiple of the half-extent)
inline constexpr double kMinQuatNorm2 = 1e-24;        // smaller quaternions: Gaussian culled

// Screen-space footprint of one Gaussian, what the per-pixel loops read.
template <class T>
struct ProjectedGaussian {
  T mx = 0, my = 0;          // centre in pixels
  T ca = 0, cb = 0, cc = 0;  // conic = cov2d^-1: power = -0.5 (ca dx^2 + cc dy^2) - cb dx dy
  T opacity = 0;             // effective opacity (after antialiasing compensation)
  T power_min = 0;           // power < power_min => alpha < kAlphaMin (slightly conservative)
  T z = 0;                   // camera depth of the centre
  T color[3] = {0, 0, 0};
  int32_t x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // inclusive pixel bbox in the image; empty if x0 > x1
};

// Intermediate values of the projection that the backward pass needs again.
template <class T>
struct ProjectionCache {
  Vec3<T> p;            // camera-space centre
  Quat<T> qn;           // normalised quaternion
  T qnorm = 1;          // |q|
  Mat3<T> rot;          // R(qn)
  Mat3<T> sigma;        // 3D covariance
  Vec3<T> t0, t1;       // rows of J R_cam
  T u = 0, v = 0;       // clamped tan-space coordinates
  bool u_free = true, v_free = true;  // false where the clamp is active (zero derivative)
  T a0 = 0, b0 = 0, c0 = 0;           // cov2d before dilation
  T a = 0, b = 0, c = 0, det = 1;     // dilated cov2d and its determinant
  T comp = 1;                         // antialiasing opacity factor
  T radius = 0;                       // half-extent of the footprint (alpha >= kAlphaMin), px
};

// Forward projection. Returns false (and leaves `out` unspecified) when the Gaussian is
// culled: centre not beyond the near plane, zero quaternion, degenerate or non-finite
// footprint, effective opacity below kAlphaMin, or a footprint that misses the image.
template <class T>
HAHA_HD bool project_gaussian(const CameraT<T>& cam, const T* mean, const T* quat, const T* scale, T opacity,
                              bool antialiased, ProjectedGaussian<T>& out, ProjectionCache<T>& c) {
  c.p = cam.R * Vec3<T>(mean[0], mean[1], mean[2]) + cam.t;
  const T z = c.p.z;
  if (!(z > cam.near_plane)) return false;  // also rejects NaN
  const Quat<T> q(quat[0], quat[1], quat[2], quat[3]);
  const T qn2 = qnorm2(q);
  if (!(qn2 > T(kMinQuatNorm2))) return false;
  c.qnorm = std::sqrt(qn2);
  c.qn = Quat<T>(q.w / c.qnorm, q.x / c.qnorm, q.y / c.qnorm, q.z / c.qnorm);
  c.rot = quat_to_mat(c.qn);
  Mat3<T> m;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) m.a[i][k] = c.rot.a[i][k] * scale[k];
  c.sigma = m * transpose(m);

  const T u_raw = c.p.x / z, v_raw = c.p.y / z;
  const T ulo = -T(kFovClamp) * cam.cx / cam.fx, uhi = T(kFovClamp) * (T(cam.width) - cam.cx) / cam.fx;
  const T vlo = -T(kFovClamp) * cam.cy / cam.fy, vhi = T(kFovClamp) * (T(cam.height) - cam.cy) / cam.fy;
  c.u_free = u_raw >= ulo && u_raw <= uhi;
  c.v_free = v_raw >= vlo && v_raw <= vhi;
  c.u = c.u_free ? u_raw : (u_raw < ulo ? ulo : uhi);
  c.v = c.v_free ? v_raw : (v_raw < vlo ? vlo : vhi);
  const T j00 = cam.fx / z, j02 = -cam.fx * c.u / z, j11 = cam.fy / z, j12 = -cam.fy * c.v / z;
  const Vec3<T> w0 = cam.R.row(0), w1 = cam.R.row(1), w2 = cam.R.row(2);
  c.t0 = j00 * w0 + j02 * w2;
  c.t1 = j11 * w1 + j12 * w2;
  const Vec3<T> st0 = c.sigma * c.t0, st1 = c.sigma * c.t1;
  c.a0 = dot(c.t0, st0);
  c.b0 = dot(c.t0, st1);
  c.c0 = dot(c.t1, st1);
  c.a = c.a0 + T(kDilation);
  c.b = c.b0;
  c.c = c.c0 + T(kDilation);
  c.det = c.a * c.c - c.b * c.b;
  if (!(c.det > 0) || !(c.a < T(1e30)) || !(c.c < T(1e30))) return false;
  c.comp = 1;
  if (antialiased) {
    const T det0 = c.a0 * c.c0 - c.b0 * c.b0;
    c.comp = det0 > 0 ? std::sqrt(det0 / c.det) : T(0);
  }
  const T o = opacity * c.comp;
  if (!(o >= T(kAlphaMin))) return false;

  out.mx = cam.fx * u_raw + cam.cx;
  out.my = cam.fy * v_raw + cam.cy;
  out.ca = c.c / c.det;
  out.cb = -c.b / c.det;
  out.cc = c.a / c.det;
  out.opacity = o;
  out.z = z;
  // alpha >= kAlphaMin  <=>  d^T conic d <= k. The bound used for culling is widened a
  // little so float rounding never drops a pixel the alpha test would keep.
  const T k = 2 * std::log(o / T(kAlphaMin)) * T(1.001) + T(1e-3);
  out.power_min = T(-0.5) * k;
  const T hx = std::sqrt(k * c.a), hy = std::sqrt(k * c.c);
  c.radius = hx > hy ? hx : hy;
  T fx0 = std::ceil(out.mx - hx - T(0.5)), fx1 = std::floor(out.mx + hx - T(0.5));
  T fy0 = std::ceil(out.my - hy - T(0.5)), fy1 = std::floor(out.my + hy - T(0.5));
  if (!(fx0 <= fx1) || !(fy0 <= fy1)) return false;  // also rejects NaN
  fx0 = fx0 < 0 ? T(0) : fx0;
  fy0 = fy0 < 0 ? T(0) : fy0;
  fx1 = fx1 > T(cam.width - 1) ? T(cam.width - 1) : fx1;
  fy1 = fy1 > T(cam.height - 1) ? T(cam.height - 1) : fy1;
  if (fx0 > fx1 || fy0 > fy1) return false;
  out.x0 = int32_t(fx0);
  out.x1 = int32_t(fx1);
  out.y0 = int32_t(fy0);
  out.y1 = int32_t(fy1);
  return true;
}

// Gradients of the loss w.r.t. the projected quantities of one Gaussian.
template <class T>
struct ProjectedGrad {
  T mx = 0, my = 0, ca = 0, cb = 0, cc = 0, opacity = 0, z = 0;
};

// Backward of project_gaussian (same cache). Writes (overwrites) d_mean[3], d_quat[4],
// d_scale[3] and *d_opacity; d_mean gets the camera-space gradient chained to world space.
template <class T>
HAHA_HD void project_gaussian_backward(const CameraT<T>& cam, const T* scale, T opacity, bool antialiased,
                                       const ProjectionCache<T>& c, const ProjectedGrad<T>& g, T* d_mean,
                                       T* d_quat, T* d_scale, T* d_opacity) {
  // Effective opacity o' = opacity * comp.
  *d_opacity = g.opacity * c.comp;
  const T d_comp = g.opacity * opacity;

  // Conic (ca, cb, cc) = (c, -b, a) / det.
  const T inv_det = T(1) / c.det;
  const T ca = c.c * inv_det, cb = -c.b * inv_det, cc = c.a * inv_det;
  const T d_det = -(g.ca * ca + g.cb * cb + g.cc * cc) * inv_det;
  T da = g.cc * inv_det + d_det * c.c;
  T dc = g.ca * inv_det + d_det * c.a;
  T db = -g.cb * inv_det - d_det * 2 * c.b;

  if (antialiased && c.comp > 0) {
    // comp = sqrt(det0 / det); det0 uses the undilated entries.
    const T r = c.comp * c.comp;
    const T d_r = d_comp * T(0.5) / c.comp;
    const T d_det0 = d_r * inv_det;
    const T d_det1 = -d_r * r * inv_det;
    da += d_det0 * c.c0 + d_det1 * c.c;
    dc += d_det0 * c.a0 + d_det1 * c.a;
    db += -2 * c.b0 * (d_det0 + d_det1);
  }
  // cov2d = (t0 S t0, t0 S t1, t1 S t1).
  const Vec3<T> st0 = c.sigma * c.t0, st1 = c.sigma * c.t1;
  Mat3<T> d_sigma = da * outer(c.t0, c.t0) + db * outer(c.t0, c.t1) + dc * outer(c.t1, c.t1);
  const Vec3<T> dt0 = (2 * da) * st0 + db * st1;
  const Vec3<T> dt1 = (2 * dc) * st1 + db * st0;

  // t0 = j00 w0 + j02 w2, t1 = j11 w1 + j12 w2.
  const Vec3<T> w0 = cam.R.row(0), w1 = cam.R.row(1), w2 = cam.R.row(2);
  const T dj00 = dot(dt0, w0), dj02 = dot(dt0, w2), dj11 = dot(dt1, w1), dj12 = dot(dt1, w2);
  const T x = c.p.x, y = c.p.y, z = c.p.z;
  const T iz = T(1) / z, iz2 = iz * iz;
  Vec3<T> dp(0, 0, 0);
  dp.z += -dj00 * cam.fx * iz2 - dj11 * cam.fy * iz2;
  dp.z += dj02 * cam.fx * c.u * iz2 + dj12 * cam.fy * c.v * iz2;
  const T du = -dj02 * cam.fx * iz, dv = -dj12 * cam.fy * iz;
  if (c.u_free) {
    dp.x += du * iz;
    dp.z -= du * x * iz2;
  }
  if (c.v_free) {
    dp.y += dv * iz;
    dp.z -= dv * y * iz2;
  }
  // mean2d (unclamped) and depth.
  dp.x += g.mx * cam.fx * iz;
  dp.y += g.my * cam.fy * iz;
  dp.z += -(g.mx * cam.fx * x + g.my * cam.fy * y) * iz2 + g.z;
  const Vec3<T> dm = transpose(cam.R) * dp;
  dm.store(d_mean);

  // Sigma = M M^T, M = R diag(s).
  Mat3<T> m;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) m.a[i][k] = c.rot.a[i][k] * scale[k];
  const Mat3<T> d_m = (d_sigma + transpose(d_sigma)) * m;
  Mat3<T> d_r;
  for (int k = 0; k < 3; ++k) {
    T s = 0;
    for (int i = 0; i < 3; ++i) {
      s += d_m.a[i][k] * c.rot.a[i][k];
      d_r.a[i][k] = d_m.a[i][k] * scale[k];
    }
    d_scale[k] = s;
  }
  // R(qn) backward.
  const T qw = c.qn.w, qx = c.qn.x, qy = c.qn.y, qz = c.qn.z;
  const auto& R = d_r.a;
  const T gw = 2 * (-qz * R[0][1] + qy * R[0][2] + qz * R[1][0] - qx * R[1][2] - qy * R[2][0] + qx * R[2][1]);
  const T gx = 2 * (qy * R[0][1] + qz * R[0][2] + qy * R[1][0] - 2 * qx * R[1][1] - qw * R[1][2] + qz * R[2][0] +
                    qw * R[2][1] - 2 * qx * R[2][2]);
  const T gy = 2 * (-2 * qy * R[0][0] + qx * R[0][1] + qw * R[0][2] + qx * R[1][0] + qz * R[1][2] - qw * R[2][0] +
                    qz * R[2][1] - 2 * qy * R[2][2]);
  const T gz = 2 * (-2 * qz * R[0][0] - qw * R[0][1] + qx * R[0][2] + qw * R[1][0] - 2 * qz * R[1][1] + qy * R[1][2] +
                    qx * R[2][0] + qy * R[2][1]);
  // Through q / |q|.
  const T proj = qw * gw + qx * gx + qy * gy + qz * gz;
  d_quat[0] = (gw - qw * proj) / c.qnorm;
  d_quat[1] = (gx - qx * proj) / c.qnorm;
  d_quat[2] = (gy - qy * proj) / c.qnorm;
  d_quat[3] = (gz - qz * proj) / c.qnorm;
}

// Rounded multiply / add / subtract that no compiler may fuse: nvcc contracts a * b + c
// into one fma by default, and would be free to do so differently in the forward and the
// backward kernel. The host build targets baseline x86-64, which has no fma instruction, so
// g++ cannot contract (even in its GNU mode's -ffp-contract=fast); host and device then
// compute these bit for bit alike. A host build with -march=native (FMA) may differ.
HAHA_HD float mul_rn(float a, float b) {
#if defined(__CUDA_ARCH__)
  return __fmul_rn(a, b);
#else
  return a * b;
#endif
}
HAHA_HD double mul_rn(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dmul_rn(a, b);
#else
  return a * b;
#endif
}
HAHA_HD float add_rn(float a, float b) {
#if defined(__CUDA_ARCH__)
  return __fadd_rn(a, b);
#else
  return a + b;
#endif
}
HAHA_HD double add_rn(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dadd_rn(a, b);
#else
  return a + b;
#endif
}

// The exponent of pixel_alpha, -0.5 (ca dx^2 + cc dy^2) - cb dx dy, with every rounding
// explicit (in the order the host evaluates the plain expression): the alpha cut and the
// clamp recomputed by the backward kernel then take exactly the forward kernel's
// decisions (the depth test and the transmittance stop are stored by the forward: `last`).
template <class T>
HAHA_HD T pixel_power(const ProjectedGaussian<T>& g, T dx, T dy) {
  const T quad = add_rn(mul_rn(mul_rn(g.ca, dx), dx), mul_rn(mul_rn(g.cc, dy), dy));
  return add_rn(mul_rn(T(-0.5), quad), -mul_rn(mul_rn(g.cb, dx), dy));
}

// Per-pixel evaluation. Returns the composited alpha, or 0 when the pixel skips the
// Gaussian (alpha < kAlphaMin). `gauss` = exp(power), `clamped` = alpha hit kAlphaMax.
template <class T>
HAHA_HD T pixel_alpha(const ProjectedGaussian<T>& g, T px, T py, T& dx, T& dy, T& gauss, bool& clamped) {
  dx = px - g.mx;
  dy = py - g.my;
  const T power = pixel_power(g, dx, dy);
  if (power < g.power_min) return T(0);
  gauss = std::exp(power);
  const T a = g.opacity * gauss;
  clamped = a > T(kAlphaMax);
  const T alpha = clamped ? T(kAlphaMax) : a;
  return alpha < T(kAlphaMin) ? T(0) : alpha;
}

// Backward of pixel_alpha given dL/dalpha: accumulates into the Gaussian's projected grad.
template <class T>
HAHA_HD void pixel_alpha_backward(const ProjectedGaussian<T>& g, T dx, T dy, T gauss, bool clamped, T d_alpha,
                                  ProjectedGrad<T>& acc) {
  if (clamped) return;  // alpha = kAlphaMax does not depend on the Gaussian
  acc.opacity += d_alpha * gauss;
  const T d_power = d_alpha * g.opacity * gauss;
  // power = -0.5 (ca dx^2 + cc dy^2) - cb dx dy, d = pixel - mean2d.
  acc.mx += d_power * (g.ca * dx + g.cb * dy);
  acc.my += d_power * (g.cb * dx + g.cc * dy);
  acc.ca += T(-0.5) * d_power * dx * dx;
  acc.cb += -d_power * dx * dy;
  acc.cc += T(-0.5) * d_power * dy * dy;
}

}  // namespace haha::gs
