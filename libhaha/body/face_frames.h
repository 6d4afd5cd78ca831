// Per-face frames of the posed mesh and the transform of face-bound Gaussians into world
// space (docs/method.md section 1), forward and backward side by side.
//
//   T = (v0 + v1 + v2) / 3
//   e = normalize(v2 - v1), n = normalize(e x (v0 - v1)), R = [e | n | e x n] (columns)
//   k = (|v0 - v2| + h) / 2 / divisor,  h = |(v2 - v1) x (v0 - v1)| / |v0 - v2|
//   mu' = k R mu + T,   r' = q(R) * r (Hamilton),   s' = k s
// q(R) is mat_to_quat(R) (w >= 0). The local rotation r is used as given (callers pass
// unit quaternions); the divisor is Avatar::face_scale_divisor (release: 0.05).
//
// Degenerate triangles. With P the perimeter and thr = kFaceDegenerateRel * P +
// kFaceTiny (one constant pair, used by forward and backward alike):
//   - |v2 - v1| <= thr: e = (1, 0, 0), held constant (zero gradient);
//   - |e x (v0 - v1)| <= thr (zero area): n = a fixed unit vector perpendicular to e
//     (built from the coordinate axis least aligned with e), no gradient through n;
//   - h divides by max(|v0 - v2|, thr); |x| has zero gradient at x = 0.
// So a zero-area or collapsed triangle gives a proper rotation, finite T, k >= 0 and
// finite gradients (k = 0 for a triangle collapsed to a point: its Gaussians get zero
// scale). Near-degenerate (but above thr) triangles have the true, large derivatives.
//
// Kernels are HAHA_HD functions; the CPU launchers below run them over arrays with
// parallel_for. All gradient outputs are ADDED to (callers zero them), as in Lbs.
#pragma once

#include <cstdint>
#include <type_traits>

#include "body/avatar.h"
#include "body/rotation.h"
#include "core/hd.h"
#include "core/math.h"

namespace haha {

constexpr double kFaceDegenerateRel = 1e-6;  // relative to the triangle's perimeter
constexpr double kFaceTiny = 1e-20;          // absolute floor, metres (float-safe)

template <class T>
struct FaceFrame {
  Vec3<T> t;
  Mat3<T> R;
  Quat<T> q;  // mat_to_quat(R)
  T k = 0;
};

// dL/d(frame): any subset may be non-zero; q and R are both inputs of the frame's users.
template <class T>
struct FaceFrameGrad {
  Vec3<T> t;
  Mat3<T> R;
  Quat<T> q{0, 0, 0, 0};
  T k = 0;
};

namespace face_detail {

template <class T>
HAHA_HD Quat<T> conj(Quat<T> q) { return {q.w, -q.x, -q.y, -q.z}; }

// Unit vector perpendicular to unit e, from the coordinate axis least aligned with it.
template <class T>
HAHA_HD Vec3<T> any_perpendicular(Vec3<T> e) {
  const T ax = std::fabs(e.x), ay = std::fabs(e.y), az = std::fabs(e.z);
  Vec3<T> axis = (ax <= ay && ax <= az) ? Vec3<T>(1, 0, 0) : (ay <= az ? Vec3<T>(0, 1, 0) : Vec3<T>(0, 0, 1));
  const Vec3<T> p = cross(e, axis);
  return p / norm(p);
}

// Shared intermediate values of forward and backward.
template <class T>
struct FrameParts {
  Vec3<T> a, b0, d02, c, cr, e, n;
  T la, ld, lc, area2, thr, den;
  bool e_ok, n_ok;
};

template <class T>
HAHA_HD FrameParts<T> frame_parts(Vec3<T> v0, Vec3<T> v1, Vec3<T> v2) {
  FrameParts<T> f;
  f.a = v2 - v1;
  f.b0 = v0 - v1;
  f.d02 = v0 - v2;
  f.la = norm(f.a);
  f.ld = norm(f.d02);
  f.thr = T(kFaceDegenerateRel) * (f.la + norm(f.b0) + f.ld) + T(kFaceTiny);
  f.e_ok = f.la > f.thr;
  f.e = f.e_ok ? f.a / f.la : Vec3<T>(1, 0, 0);
  f.c = cross(f.e, f.b0);
  f.lc = norm(f.c);
  f.n_ok = f.lc > f.thr;
  f.n = f.n_ok ? f.c / f.lc : any_perpendicular(f.e);
  f.cr = cross(f.a, f.b0);
  f.area2 = norm(f.cr);
  f.den = f.ld > f.thr ? f.ld : f.thr;
  return f;
}

}  // namespace face_detail

template <class T>
HAHA_HD FaceFrame<T> face_frame(Vec3<T> v0, Vec3<T> v1, Vec3<T> v2, T divisor) {
  const face_detail::FrameParts<T> p = face_detail::frame_parts(v0, v1, v2);
  FaceFrame<T> f;
  f.t = (v0 + v1 + v2) / T(3);
  f.R = Mat3<T>::from_cols(p.e, p.n, cross(p.e, p.n));
  f.q = mat_to_quat(f.R);
  const T h = p.area2 / p.den;
  f.k = (p.ld + h) / (T(2) * divisor);
  return f;
}

// Adds dL/dv0, dL/dv1, dL/dv2 for dL/d(frame) g.
template <class T>
HAHA_HD void face_frame_backward(Vec3<T> v0, Vec3<T> v1, Vec3<T> v2, T divisor, const FaceFrameGrad<T>& g,
                                 Vec3<T>& dv0, Vec3<T>& dv1, Vec3<T>& dv2) {
  const face_detail::FrameParts<T> p = face_detail::frame_parts(v0, v1, v2);
  const Vec3<T> bvec = cross(p.e, p.n);
  const Mat3<T> R = Mat3<T>::from_cols(p.e, p.n, bvec);
  const Mat3<T> dR = g.R + mat_to_quat_backward(R, g.q);
  Vec3<T> de = dR.col(0), dn = dR.col(1);
  const Vec3<T> db = dR.col(2);
  // bvec = e x n
  de += cross(p.n, db);
  dn += cross(db, p.e);
  Vec3<T> da{}, db0{}, dd02{};
  if (p.n_ok) {  // n = c / |c|, c = e x b0
    const Vec3<T> dc = (dn - dot(p.n, dn) * p.n) / p.lc;
    de += cross(p.b0, dc);
    db0 += cross(dc, p.e);
  }
  if (p.e_ok) da += (de - dot(p.e, de) * p.e) / p.la;
  // k = (ld + area2 / den) / (2 divisor)
  const T dsum = g.k / (T(2) * divisor);
  T dld = dsum;
  const T darea2 = dsum / p.den;
  if (p.ld > p.thr) dld -= dsum * p.area2 / (p.den * p.den);
  if (p.area2 > T(0)) {
    const Vec3<T> dcr = (darea2 / p.area2) * p.cr;  // cr = a x b0
    da += cross(p.b0, dcr);
    db0 += cross(dcr, p.a);
  }
  if (p.ld > T(0)) dd02 += (dld / p.ld) * p.d02;
  const Vec3<T> dt = g.t / T(3);
  dv0 += dt + db0 + dd02;
  dv1 += dt - da - db0;
  dv2 += dt + da - dd02;
}

// One Gaussian in its face's frame -> world.
template <class T>
HAHA_HD void pose_gaussian(const FaceFrame<T>& f, Vec3<T> mu, Quat<T> r, Vec3<T> s, Vec3<T>& mu_w, Quat<T>& r_w,
                           Vec3<T>& s_w) {
  mu_w = f.k * (f.R * mu) + f.t;
  r_w = f.q * r;
  s_w = f.k * s;
}

// Backward of pose_gaussian: adds dL/dmu, dL/dr, dL/ds and the frame gradient.
template <class T>
HAHA_HD void pose_gaussian_backward(const FaceFrame<T>& f, Vec3<T> mu, Quat<T> r, Vec3<T> s, Vec3<T> d_mu_w,
                                    Quat<T> d_r_w, Vec3<T> d_s_w, Vec3<T>& d_mu, Quat<T>& d_r, Vec3<T>& d_s,
                                    FaceFrameGrad<T>& df) {
  const Vec3<T> Rmu = f.R * mu;
  d_mu += f.k * (transpose(f.R) * d_mu_w);
  d_s += f.k * d_s_w;
  df.t += d_mu_w;
  df.k += dot(d_mu_w, Rmu) + dot(d_s_w, s);
  df.R = df.R + f.k * outer(d_mu_w, mu);
  // p = q * r is bilinear: dL/dq = dp * conj(r), dL/dr = conj(q) * dp.
  const Quat<T> dq = d_r_w * face_detail::conj(r);
  const Quat<T> dr = face_detail::conj(f.q) * d_r_w;
  df.q = {df.q.w + dq.w, df.q.x + dq.x, df.q.y + dq.y, df.q.z + dq.z};
  d_r = {d_r.w + dr.w, d_r.x + dr.x, d_r.y + dr.y, d_r.z + dr.z};
}

// ---- CPU launchers (face_frames.cpp; instantiated for float and double) ----

// Local Gaussian parameters as raw arrays: face (N), offset (N,3), rotation (N,4 w,x,y,z),
// scale (N,3).
template <class T>
struct GaussianLocalView {
  int n = 0;
  const int32_t* face = nullptr;
  const T* offset = nullptr;
  const T* rotation = nullptr;
  const T* scale = nullptr;
};

// verts (V,3), faces (F,3) -> frames (F).
template <class T>
void compute_face_frames(const T* verts, const int32_t* faces, int num_faces, T divisor, FaceFrame<T>* frames);

// Adds dL/dverts (V,3) for per-face dL/dframe (F).
template <class T>
void face_frames_backward(const T* verts, const int32_t* faces, int num_faces, T divisor,
                          const FaceFrameGrad<T>* d_frames, T* d_verts);

// World-space Gaussians: means (N,3), quats (N,4 w,x,y,z), scales (N,3), caller-allocated.
// Throws haha::Error if a Gaussian's face index is outside [0, num_faces).
template <class T>
void pose_gaussians(const T* verts, const int32_t* faces, int num_faces, T divisor, const GaussianLocalView<T>& g,
                    T* means, T* quats, T* scales);

// Backward: given dL/d(means, quats, scales) (any may be null = zero), ADDS, where the
// pointer is non-null, dL/dverts (V,3) and dL/d(offset (N,3), rotation (N,4), scale
// (N,3)). Deterministic: per-face sums are taken in Gaussian order. (The optional
// pointers are non-deduced so that nullptr can be passed.)
template <class T>
void pose_gaussians_backward(const T* verts, const int32_t* faces, int num_faces, T divisor,
                             const GaussianLocalView<T>& g, const std::type_identity_t<T>* d_means,
                             const std::type_identity_t<T>* d_quats, const std::type_identity_t<T>* d_scales,
                             std::type_identity_t<T>* d_verts, std::type_identity_t<T>* d_offset,
                             std::type_identity_t<T>* d_rotation,
                             std::type_identity_t<T>* d_scale);

// Convenience for the stored avatar (float): posed verts (V,3) of `body`.
void pose_gaussians(const float* verts, const BodyModel& body, float divisor, const BoundGaussians& g, float* means,
                    float* quats, float* scales);
GaussianLocalView<float> view_of(const BoundGaussians& g);

}  // namespace haha
