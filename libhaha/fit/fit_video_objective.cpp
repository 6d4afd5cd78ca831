// The video fit's objective and its gradient (fit/fit_video_objective.h).
#include "fit/fit_video_objective.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {

double fit_video_prior_factor(int k) {
  if (k < 3 || k >= kFitVideoPoseValues) return 0;
  const int joint = k / 3, axis = k % 3;
  switch (joint) {
    case 3: case 6: case 9: return 10;    // spine
    case 13: case 14: return 10;          // collars
    case 12: case 15: return 3;           // neck, head
    case 7: case 8: return 3;             // ankles
    case 10: case 11: return 20;          // feet (toes): the keypoints hardly see them
    case 20: case 21: return 3;           // wrists: no hand points used
    case 4: case 5: return axis == 0 ? 0.3 : 10;  // knees: hinges about x, flexing freely
    case 18: case 19: return axis == 1 ? 0.3 : 1;   // elbows flex about y
    default: return 1;
  }
}

namespace {

// Bend limits: pose value index and the sign s of the allowed bend (penalty max(0, -s theta)^2).
struct Limit {
  int k;
  double s;
};
constexpr Limit kLimits[] = {{3 * 4 + 0, 1}, {3 * 5 + 0, 1}, {3 * 18 + 1, -1}, {3 * 19 + 1, 1}};

}  // namespace

template <class T>
FitVideoObjective<T>::FitVideoObjective(const BodyModel& body, std::vector<FitVideoPoint> points,
                                        const CameraT<T>& camera, int num_betas, const FitVideoWeights& w)
    : lbs_(body), points_(std::move(points)), bones_(fit_video_bones(points_)), cam_(camera), nb_(std::max(0, std::min(num_betas, body.num_shape))), w_(w) {
  for (const FitVideoPoint& p : points_) {
    if ((p.joint < 0) == (p.vertex < 0) || p.joint >= kNumJoints || p.vertex >= body.num_verts)
      fail("video fit", "point " + p.name + " names neither one joint nor one vertex of the body");
    point_w_.push_back(p.weight);
  }
}

template <class T>
SmplxParams FitVideoObjective<T>::to_params(const T* q, const T* betas, int num_betas) {
  SmplxParams p;
  for (int k = 0; k < kFitVideoPoseValues; ++k) p.pose[size_t(k)] = float(q[k]);
  for (int c = 0; c < 3; ++c) p.transl[size_t(c)] = float(q[kFitVideoPoseValues + c]);
  for (int k = 0; k < num_betas; ++k) p.betas.push_back(float(betas[k]));
  return p;
}

template <class T>
void FitVideoObjective<T>::pose_frame(const T* q, const T* betas, std::vector<T>& pose, std::vector<T>& verts,
                                      std::vector<T>& joints, LbsCache<T>* cache) const {
  pose.assign(kNumPoseValues, T(0));
  std::copy(q, q + kFitVideoPoseValues, pose.begin());
  verts.resize(size_t(lbs_.num_verts()) * 3);
  joints.resize(size_t(kNumJoints) * 3);
  const SmplxView<T> view{pose.data(), betas, nb_, nullptr, 0, q + kFitVideoPoseValues};
  lbs_.forward(view, verts.data(), joints.data(), cache);
}

template <class T>
std::vector<Vec3<T>> FitVideoObjective<T>::camera_points(const T* q, const T* betas) const {
  std::vector<T> pose, verts, joints;
  pose_frame(q, betas, pose, verts, joints, nullptr);
  std::vector<Vec3<T>> c;
  for (const FitVideoPoint& p : points_)
    c.push_back(cam_.to_camera(Vec3<T>::load(p.joint >= 0 ? &joints[size_t(3 * p.joint)] : &verts[size_t(3 * p.vertex)])));
  return c;
}

template <class T>
void FitVideoObjective<T>::project(const T* q, const T* betas, std::vector<T>& u, std::vector<T>& v) const {
  const std::vector<Vec3<T>> cp = camera_points(q, betas);
  u.resize(points_.size());
  v.resize(points_.size());
  for (size_t k = 0; k < points_.size(); ++k) {
    Vec3<T> c = cp[k];
    c.z = std::max(c.z, T(kFitVideoMinDepth));
    const Vec2<T> px = cam_.project(c);
    u[k] = px.x;
    v[k] = px.y;
  }
}

template <class T>
T FitVideoObjective<T>::evaluate(const std::vector<FitVideoTargets>& targets, const T* params, T* grad,
                                 const Extra& extra, FitVideoTerms* terms) const {
  const int N = int(targets.size());
  const T* betas = params + size_t(N) * kFitVideoFrameParams;
  if (grad) std::fill(grad, grad + num_params(N), T(0));
  FitVideoTerms t;
  const T invN = T(1) / T(std::max(1, N));
  const T H = T(cam_.height), sig2 = T(w_.gm_sigma * w_.gm_sigma);
  const Mat3<T> Rt = transpose(cam_.R);
  const size_t K = points_.size();
  std::vector<T> pose, verts, joints, d_verts, d_joints;
  LbsCache<T> cache;
  for (int f = 0; f < N; ++f) {
    const FitVideoTargets& tg = targets[size_t(f)];
    if (tg.x.size() != K || tg.y.size() != K || tg.vis.size() != K || (!tg.world.empty() && tg.world.size() != 3 * K))
      fail("video fit", "targets of frame " + std::to_string(f) + " do not match the correspondence");
    const T* q = params + size_t(f) * kFitVideoFrameParams;
    pose_frame(q, betas, pose, verts, joints, grad ? &cache : nullptr);
    if (grad) {
      d_verts.assign(verts.size(), T(0));
      d_joints.assign(joints.size(), T(0));
    }
    double e_kp = 0, e_behind = 0;
    for (size_t k = 0; k < K; ++k) {
      const FitVideoPoint& p = points_[k];
      const T c = T(point_w_[k] * tg.vis[k]);
      const T* x = p.joint >= 0 ? &joints[size_t(3 * p.joint)] : &verts[size_t(3 * p.vertex)];
      const Vec3<T> xc = cam_.to_camera(Vec3<T>::load(x));
      Vec3<T> g(T(0), T(0), T(0));  // dE/d(camera-space point), before 1/N
      const bool clamped = xc.z < T(kFitVideoMinDepth);
      if (clamped) {
        const T d = T(kFitVideoMinDepth) - xc.z;
        e_behind += double(T(w_.behind) * d * d);
        g.z = T(-2 * w_.behind) * d;
      }
      if (c > T(0)) {
        const T z = clamped ? T(kFitVideoMinDepth) : xc.z;
        const T u = cam_.fx * xc.x / z + cam_.cx, v = cam_.fy * xc.y / z + cam_.cy;
        const T ru = (u - T(tg.x[k])) / H, rv = (v - T(tg.y[k])) / H;
        const T s = ru * ru + rv * rv;
        e_kp += double(T(w_.keypoints) * c * sig2 * s / (sig2 + s));
        // d rho / d s = sigma^4 / (sigma^2 + s)^2
        const T drho = T(w_.keypoints) * c * sig2 * sig2 / ((sig2 + s) * (sig2 + s));
        const T gu = drho * T(2) * ru / H, gv = drho * T(2) * rv / H;
        g.x += gu * cam_.fx / z;
        g.y += gv * cam_.fy / z;
        if (!clamped) g.z += -(gu * cam_.fx * xc.x + gv * cam_.fy * xc.y) / (z * z);
      }
      if (grad) {
        const Vec3<T> gw = invN * (Rt * g);
        T* d = p.joint >= 0 ? &d_joints[size_t(3 * p.joint)] : &d_verts[size_t(3 * p.vertex)];
        d[0] += gw.x, d[1] += gw.y, d[2] += gw.z;
      }
    }
    if (w_.world > 0 && !tg.world.empty()) {
      const T sw2 = T(w_.world_sigma * w_.world_sigma);
      double e_w = 0;
      for (const FitVideoBone& b : bones_) {
        const T c = T(w_.world * std::min(tg.vis[size_t(b.a)], tg.vis[size_t(b.b)]));
        const double* wa = &tg.world[size_t(3 * b.a)];
        const double* wb = &tg.world[size_t(3 * b.b)];
        Vec3d e(wb[0] - wa[0], wb[1] - wa[1], wb[2] - wa[2]);
        const double el = norm(e);
        if (!(c > T(0)) || !(el > 1e-6)) continue;
        e = e / el;
        const T* xa = &joints[size_t(3 * points_[size_t(b.a)].joint)];
        const T* xb = &joints[size_t(3 * points_[size_t(b.b)].joint)];
        const Vec3<T> u = cam_.R * (Vec3<T>::load(xb) - Vec3<T>::load(xa));  // camera axes
        const T l = norm(u);
        if (!(l > T(1e-9))) continue;
        const Vec3<T> d = u / l, r = d - Vec3<T>(T(e.x), T(e.y), T(e.z));
        const T s = dot(r, r);
        e_w += double(c * sw2 * s / (sw2 + s));
        if (!grad) continue;
        const T drho = c * sw2 * sw2 / ((sw2 + s) * (sw2 + s));
        const Vec3<T> gd = (T(2) * drho) * r;                    // dE/dd
        const Vec3<T> gu = (gd - dot(gd, d) * d) / l;            // through d = u / |u|
        const Vec3<T> gw = invN * (Rt * gu);
        T* da = &d_joints[size_t(3 * points_[size_t(b.a)].joint)];
        T* db = &d_joints[size_t(3 * points_[size_t(b.b)].joint)];
        da[0] -= gw.x, da[1] -= gw.y, da[2] -= gw.z;
        db[0] += gw.x, db[1] += gw.y, db[2] += gw.z;
      }
      t.world += e_w / N;
    }
    t.keypoints += e_kp / N;
    t.behind += e_behind / N;
    if (extra) t.extra += double(extra(f, verts.data(), grad ? d_verts.data() : nullptr));
    T* gq = grad ? grad + size_t(f) * kFitVideoFrameParams : nullptr;
    if (grad) {
      SmplxGrad<T> sg;
      sg.betas.assign(size_t(nb_), T(0));
      const SmplxView<T> view{pose.data(), betas, nb_, nullptr, 0, q + kFitVideoPoseValues};
      lbs_.backward(view, cache, d_verts.data(), d_joints.data(), sg);
      for (int k = 0; k < kFitVideoPoseValues; ++k) gq[k] += sg.pose[size_t(k)];
      for (int c = 0; c < 3; ++c) gq[kFitVideoPoseValues + c] += sg.transl[size_t(c)];
      for (int k = 0; k < nb_; ++k) grad[size_t(N) * kFitVideoFrameParams + size_t(k)] += sg.betas[size_t(k)];
    }
    // Prior and bend limits.
    for (int k = 3; k < kFitVideoPoseValues; ++k) {
      const T a = T(w_.pose_prior * fit_video_prior_factor(k));
      t.prior += double(a * q[k] * q[k]) / N;
      if (gq) gq[k] += invN * T(2) * a * q[k];
    }
    for (const Limit& l : kLimits) {
      const T b = -T(l.s) * q[l.k];
      if (b <= T(0)) continue;
      t.limits += double(T(w_.angle_limit) * b * b) / N;
      if (gq) gq[l.k] += invN * T(2 * w_.angle_limit) * b * T(-l.s);
    }
    // Smoothness with the previous frame.
    if (tg.linked && f > 0) {
      if (!(tg.dt > 0) || !std::isfinite(tg.dt))
        fail("video fit", "frame " + std::to_string(f) + ": time since the previous frame must be > 0");
      const double time_scale = (kFitVideoSmoothInterval / tg.dt) * (kFitVideoSmoothInterval / tg.dt);
      const T* qp = q - kFitVideoFrameParams;
      T* gp = grad ? gq - kFitVideoFrameParams : nullptr;
      for (int k = 0; k < kFitVideoFrameParams; ++k) {
        const bool robust = k >= 3 && k < kFitVideoPoseValues && w_.smooth_sigma > 0;
        const T s2 = T(w_.smooth_sigma * w_.smooth_sigma);
        const T w = T(time_scale * (k < kFitVideoPoseValues ? w_.smooth_pose : w_.smooth_transl));
        const T d = q[k] - qp[k];
        T e = w * d * d, g = T(2) * w * d;  // the value and its derivative by d
        if (robust) {  // w s2 v^2 / (s2 + v^2) of v^2 = time_scale d^2 (the change per dt_ref)
          const T v2 = T(time_scale) * d * d;
          e = T(w_.smooth_pose) * s2 * v2 / (s2 + v2);
          g = T(w_.smooth_pose) * s2 * s2 / ((s2 + v2) * (s2 + v2)) * T(2 * time_scale) * d;
        }
        t.smooth += double(e) / N;
        if (grad) {
          gq[k] += invN * g;
          gp[k] -= invN * g;
        }
      }
    }
  }
  for (int k = 0; k < nb_; ++k) {
    t.betas += w_.betas * double(betas[k]) * double(betas[k]);
    if (grad) grad[size_t(N) * kFitVideoFrameParams + size_t(k)] += T(2 * w_.betas) * betas[k];
  }
  if (terms) *terms = t;
  return T(t.total());
}

template class FitVideoObjective<float>;
template class FitVideoObjective<double>;

}  // namespace haha
