#include "fit/fit_video_world_init.h"

#include <cmath>
#include <numbers>

#include "body/rotation.h"
#include "io/keypoints_json.h"

namespace haha {

namespace {

constexpr double kPi = std::numbers::pi;

// Body axes (columns: left, up, forward) from the two hips and two shoulders.
bool torso_frame(Vec3d lhip, Vec3d rhip, Vec3d lsh, Vec3d rsh, Mat3<double>& B) {
  const Vec3d left = (lhip - rhip) + (lsh - rsh), up = 0.5 * (lsh + rsh) - 0.5 * (lhip + rhip);
  if (!(norm(up) > 1e-6)) return false;
  const Vec3d y = up / norm(up);
  Vec3d x = left - dot(left, y) * y;
  if (!(norm(x) > 1e-6)) return false;
  x = x / norm(x);
  const Vec3d z = cross(x, y);
  for (int r = 0; r < 3; ++r) B(r, 0) = x[r], B(r, 1) = y[r], B(r, 2) = z[r];
  return true;
}

}  // namespace

Vec3d rotation_between(Vec3d a, Vec3d b) {
  a = a / norm(a), b = b / norm(b);
  const Vec3d c = cross(a, b);
  const double s = norm(c), co = dot(a, b);
  if (s > 1e-9) return c * (std::atan2(s, co) / s);
  if (co > 0) return Vec3d(0, 0, 0);
  Vec3d p = std::abs(a.x) < 0.9 ? cross(a, Vec3d(1, 0, 0)) : cross(a, Vec3d(0, 1, 0));  // opposite: any perpendicular
  return p * (kPi / norm(p));
}

bool init_pose_from_world(const BodyModel& body, const std::vector<FitVideoPoint>& points, const FitVideoTargets& tg,
                          const std::vector<float>& rest_joints, const Mat3<double>& cam_R, double min_visibility,
                          float* q) {
  if (tg.world.size() != 3 * points.size()) return false;
  auto point_of_joint = [&](int joint) {
    for (size_t k = 0; k < points.size(); ++k)
      if (points[k].joint == joint) return int(k);
    return -1;
  };
  auto seen = [&](int k) { return k >= 0 && tg.vis[size_t(k)] >= min_visibility; };
  // World points in the fit's world axes (the camera's rotation undone; positions only matter
  // as differences).
  const Mat3<double> Rt = transpose(cam_R);
  auto W = [&](int k) { return Rt * Vec3d(tg.world[size_t(3 * k)], tg.world[size_t(3 * k + 1)], tg.world[size_t(3 * k + 2)]); };
  auto J = [&](int j) { return Vec3d(rest_joints[size_t(3 * j)], rest_joints[size_t(3 * j + 1)], rest_joints[size_t(3 * j + 2)]); };

  constexpr int kLHip = 1, kRHip = 2, kLShoulder = 16, kRShoulder = 17;
  const int lh = point_of_joint(kLHip), rh = point_of_joint(kRHip), ls = point_of_joint(kLShoulder),
            rs = point_of_joint(kRShoulder);
  if (!seen(lh) || !seen(rh) || !seen(ls) || !seen(rs)) return false;
  Mat3<double> Bw, Br;
  if (!torso_frame(W(lh), W(rh), W(ls), W(rs), Bw) || !torso_frame(J(kLHip), J(kRHip), J(kLShoulder), J(kRShoulder), Br))
    return false;
  const Mat3<double> orient = Bw * transpose(Br);
  const Vec3d w0 = matrix_to_axis_angle(orient);
  for (int c = 0; c < 3; ++c) q[c] = float(w0[c]);

  // Limbs, parents first: each joint turns its rest bone onto the world bone, given the
  // rotations above it (global orient, then what this loop has set).
  auto global = [&](int j) {
    Mat3<double> G = Mat3<double>::identity();
    for (; j >= 0; j = body.parents[size_t(j)]) G = rodrigues(Vec3d(q[3 * j], q[3 * j + 1], q[3 * j + 2])) * G;
    return G;
  };
  constexpr int kLimbs[][2] = {{16, 18}, {17, 19}, {1, 4}, {2, 5}, {18, 20}, {19, 21}, {4, 7}, {5, 8}};
  for (const auto& l : kLimbs) {
    const int a = point_of_joint(l[0]), b = point_of_joint(l[1]);
    if (!seen(a) || !seen(b)) continue;
    const Vec3d target = W(b) - W(a), rest = J(l[1]) - J(l[0]);
    if (!(norm(target) > 1e-6) || !(norm(rest) > 1e-6)) continue;
    const int parent = body.parents[size_t(l[0])];
    const Vec3d local = transpose(global(parent)) * target;  // the target in the parent's frame
    const Vec3d w = rotation_between(rest, local);
    for (int c = 0; c < 3; ++c) q[3 * l[0] + c] = float(w[c]);
  }
  return true;
}

}  // namespace haha
