#include "app/motion_retarget_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "body/rotation.h"

namespace haha {

namespace {

using V3 = Vec3<double>;
using M3 = Mat3<double>;

// Joint pairs of each limb (both sides where there are two).
constexpr int kPairs[RetargetCheck::kLimbs][2][2] = {{{16, 18}, {17, 19}}, {{18, 20}, {19, 21}}, {{1, 4}, {2, 5}},
                                                     {{4, 7}, {5, 8}},     {{0, 9}, {-1, -1}},   {{12, 15}, {-1, -1}}};

// The body's posed joints (forward kinematics of the rest skeleton; SMPL-X joints do not
// depend on the pose correctives).
std::vector<V3> posed_joints(const SmplxParams& p, const RestSkeleton& s) {
  std::vector<M3> G(kNumJoints);
  std::vector<V3> J(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) {
    const M3 L = rodrigues(V3(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)]));
    const int par = s.parents[size_t(j)];
    G[size_t(j)] = par < 0 ? L : G[size_t(par)] * L;
    J[size_t(j)] = par < 0 ? s.joints[0] + V3(p.transl[0], p.transl[1], p.transl[2])
                           : J[size_t(par)] + G[size_t(par)] * (s.joints[size_t(j)] - s.joints[size_t(par)]);
  }
  return J;
}

double angle_deg(const V3& a, const V3& b) {
  const double c = dot(a, b) / (norm(a) * norm(b));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
}

// Contact runs [begin, end) of one ankle track (metres, Y up).
std::vector<std::pair<size_t, size_t>> contact_runs(const std::vector<V3>& x, double fps, const FootLockParams& o) {
  double low = INFINITY;
  for (const V3& p : x) low = std::min(low, p.y);
  std::vector<std::pair<size_t, size_t>> runs;
  const size_t T = x.size();
  size_t start = T;
  for (size_t t = 0; t <= T; ++t) {
    bool c = false;
    if (t < T) {
      const size_t a = t > 0 ? t - 1 : t, b = std::min(t + 1, T - 1);
      const double speed = b > a ? norm(x[b] - x[a]) * fps / double(b - a) : 0;
      c = speed < o.contact_speed && x[t].y - low < o.contact_height;
    }
    if (c && start == T) start = t;
    if (!c && start < T) {
      if (int(t - start) >= o.min_contact_frames) runs.emplace_back(start, t);
      start = T;
    }
  }
  return runs;
}

// Distance from p to the polyline through pts.
double distance_to_polyline(const V3& p, const std::vector<V3>& pts) {
  double best = INFINITY;
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const V3 a = pts[i], d = pts[i + 1] - a;
    const double len2 = dot(d, d);
    const double t = len2 > 0 ? std::clamp(dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, norm(p - (a + t * d)));
  }
  return best;
}

// Whether an elbow or wrist of `pos` (joint -> metres, NaN-free for bound joints) is within
// kTorsoRadius of the pelvis-spine-neck line; `has` says which joints are there.
template <class Pos, class Has>
bool arm_in_torso(const Pos& pos, const Has& has) {
  std::vector<V3> line;
  for (int j : {0, 3, 6, 9, 12})
    if (has(j)) line.push_back(pos(j));
  if (line.size() < 2) return false;
  for (int j : {18, 19, 20, 21})
    if (has(j) && distance_to_polyline(pos(j), line) < RetargetCheck::kTorsoRadius) return true;
  return false;
}

double slide(const std::vector<V3>& x, size_t a, size_t b) {
  double d = 0;
  for (size_t t = a; t < b; ++t) d = std::max(d, std::hypot(x[t].x - x[a].x, x[t].z - x[a].z));
  return d;
}

}  // namespace

RetargetCheck check_retarget(const RigAnimation& rig, const BoneMatch& match, const Motion& m, const RestSkeleton& body,
                             const RetargetReport& rep, const FootLockParams& o) {
  RetargetCheck c;
  const size_t T = std::min(rig.frames.size(), m.frames.size());
  std::array<double, RetargetCheck::kLimbs> sum{};
  std::array<int, RetargetCheck::kLimbs> n{};
  std::vector<V3> rig_ankle[2], body_ankle[2];
  for (size_t t = 0; t < T; ++t) {
    const std::vector<Affine> w = world_transforms(rig, rig.frames[t]);
    const std::vector<V3> J = posed_joints(m.frames[t], body);
    const auto rig_pos = [&](int j) { return w[size_t(match.node_of[size_t(j)])].t; };
    for (int l = 0; l < RetargetCheck::kLimbs; ++l)
      for (const auto& pr : kPairs[l]) {
        if (pr[0] < 0 || match.node_of[size_t(pr[0])] < 0 || match.node_of[size_t(pr[1])] < 0) continue;
        // The rig's world turned to haha's, as the retargeter turned it.
        const V3 ds = rig_pos(pr[1]) - rig_pos(pr[0]), dt = J[size_t(pr[1])] - J[size_t(pr[0])];
        sum[size_t(l)] += angle_deg(rep.alignment * ds, dt);
        ++n[size_t(l)];
      }
    const bool body_in = arm_in_torso([&](int j) { return J[size_t(j)]; }, [&](int j) { return match.node_of[size_t(j)] >= 0; });
    const bool rig_in = arm_in_torso([&](int j) { return rep.scale * (rep.alignment * rig_pos(j)); },
                                     [&](int j) { return match.node_of[size_t(j)] >= 0; });
    ++c.frames;
    c.arm_in_torso_frames += body_in && !rig_in;
    c.rig_arm_in_torso_frames += rig_in;
    for (int f = 0; f < 2; ++f) {
      const int a = 7 + f;
      if (match.node_of[size_t(a)] < 0) continue;
      rig_ankle[f].push_back(rep.scale * (rep.alignment * rig_pos(a)));
      body_ankle[f].push_back(J[size_t(a)]);
    }
  }
  for (int l = 0; l < RetargetCheck::kLimbs; ++l) c.limb_deg[size_t(l)] = n[size_t(l)] ? sum[size_t(l)] / n[size_t(l)] : NAN;
  for (int f = 0; f < 2; ++f)
    for (const auto& [a, b] : contact_runs(rig_ankle[f], m.fps, o)) {
      ++c.contacts;
      c.slide_cm += 100 * slide(body_ankle[f], a, b);
      c.rig_slide_cm += 100 * slide(rig_ankle[f], a, b);
    }
  if (c.contacts) c.slide_cm /= c.contacts, c.rig_slide_cm /= c.contacts;
  return c;
}

std::string retarget_check_line(const RetargetCheck& c) {
  std::string s = "limb directions against the rig (mean):";
  char b[96];
  for (int l = 0; l < RetargetCheck::kLimbs; ++l) {
    if (std::isnan(c.limb_deg[size_t(l)])) continue;
    std::snprintf(b, sizeof b, " %s %.2f deg,", RetargetCheck::kLimbNames[l], c.limb_deg[size_t(l)]);
    s += b;
  }
  std::snprintf(b, sizeof b, " ankles slide %.2f cm in the rig's %d contacts (the rig's own %.2f cm),", c.slide_cm, c.contacts,
                c.rig_slide_cm);
  s += b;
  std::snprintf(b, sizeof b, " an arm inside the torso in %d of %d frames where the rig's is not (the rig's in %d)",
                c.arm_in_torso_frames, c.frames, c.rig_arm_in_torso_frames);
  return s + b;
}

}  // namespace haha
