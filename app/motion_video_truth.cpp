#include "app/motion_video_truth.h"

#include <algorithm>
#include <cmath>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/error.h"

namespace haha {

namespace {

using V3 = Vec3<double>;
constexpr int kBodyJoints = 22;  // pelvis + 21 body joints

std::vector<V3> posed_joints(const Lbs<double>& lbs, int num_verts, const SmplxParams& p) {
  std::vector<double> verts(size_t(num_verts) * 3), j(size_t(kNumJoints) * 3);
  lbs.forward(p, verts.data(), j.data(), nullptr);
  std::vector<V3> out;
  for (int k = 0; k < kNumJoints; ++k) out.push_back(V3(j[size_t(3 * k)], j[size_t(3 * k + 1)], j[size_t(3 * k + 2)]));
  return out;
}

// Body joints relative to the pelvis, turned by R.
std::vector<V3> root_aligned(const std::vector<V3>& j, const Mat3<double>& R) {
  std::vector<V3> out;
  for (int k = 0; k < kBodyJoints; ++k) out.push_back(R * (j[size_t(k)] - j[0]));
  return out;
}

// Runs of at least min_frames frames where the foot is slow and low.
std::vector<std::pair<size_t, size_t>> contacts(const std::vector<V3>& foot, double fps, double speed, double height,
                                                int min_frames) {
  double low = INFINITY;
  for (const V3& x : foot) low = std::min(low, x.y);
  const size_t T = foot.size();
  std::vector<char> c(T, 0);
  for (size_t t = 0; t < T; ++t) {
    const size_t a = t > 0 ? t - 1 : t, b = std::min(t + 1, T - 1);
    const double v = b > a ? norm(foot[b] - foot[a]) * fps / double(b - a) : 0;
    c[t] = v < speed && foot[t].y - low < height;
  }
  std::vector<std::pair<size_t, size_t>> runs;
  for (size_t t = 0; t < T;) {
    size_t e = t;
    while (e < T && c[e] == c[t]) ++e;
    if (c[t] && int(e - t) >= min_frames) runs.push_back({t, e});
    t = e;
  }
  return runs;
}

}  // namespace

MotionTruthErrors motion_truth_errors(const Motion& m, const std::vector<int>& idx, const FitVideoTruth& truth,
                                      const BodyModel& player, double contact_speed, double contact_height, int min_frames) {
  if (idx.size() != m.frames.size()) fail(truth.dir, "motion and truth frames differ in number");
  const Lbs<double> tl(truth.body), pl(player);
  // The motion's world is the camera's turned Y-up (a half turn about x): see the truth there.
  Mat3<double> C = Mat3<double>::identity();
  C.a[1][1] = C.a[2][2] = -1;
  std::vector<std::vector<V3>> est, tru;
  std::vector<V3> true_feet[2], motion_feet[2];
  for (size_t t = 0; t < m.frames.size(); ++t) {
    const size_t k = size_t(idx[t]);
    if (k >= truth.params.size()) fail(truth.dir, "has no frame " + std::to_string(k));
    const Camera& cam = truth.cameras[k];
    Mat3<double> Rc;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Rc.a[r][c] = cam.R.a[r][c];
    const std::vector<V3> tj = posed_joints(tl, truth.body.num_verts, truth.params[k]);
    tru.push_back(root_aligned(tj, C * Rc));
    SmplxParams p = m.frames[t];
    p.betas = truth.params[k].betas;  // the pose alone: the true body wears both
    est.push_back(root_aligned(posed_joints(tl, truth.body.num_verts, p), Mat3<double>::identity()));
    const std::vector<V3> pj = posed_joints(pl, player.num_verts, m.frames[t]);
    for (int f = 0; f < 2; ++f) true_feet[f].push_back(tj[size_t(10 + f)]), motion_feet[f].push_back(pj[size_t(10 + f)]);
  }
  MotionTruthErrors e;
  const size_t T = est.size();
  for (size_t t = 0; t < T; ++t)
    for (int k = 0; k < kBodyJoints; ++k) e.joint_mm += 1000 * norm(est[t][size_t(k)] - tru[t][size_t(k)]) / double(T * kBodyJoints);
  for (size_t t = 1; t + 1 < T; ++t)
    for (int k = 0; k < kBodyJoints; ++k) {
      const size_t j = size_t(k);
      const V3 ae = est[t + 1][j] - 2.0 * est[t][j] + est[t - 1][j], at = tru[t + 1][j] - 2.0 * tru[t][j] + tru[t - 1][j];
      e.accel_error += norm(ae - at) * m.fps * m.fps / double((T - 2) * kBodyJoints);
    }
  for (int f = 0; f < 2; ++f)
    for (const auto& [a, b] : contacts(true_feet[f], m.fps, contact_speed, contact_height, min_frames)) {
      double travel = 0;
      for (size_t t = a; t < b; ++t) {
        const V3 d = motion_feet[f][t] - motion_feet[f][a];
        travel = std::max(travel, std::sqrt(d.x * d.x + d.z * d.z));
      }
      e.slide_cm += 100 * travel;
      ++e.contacts;
    }
  if (e.contacts) e.slide_cm /= e.contacts;
  return e;
}

}  // namespace haha
