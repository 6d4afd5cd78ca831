#include "app/motion_retarget.h"

#include <algorithm>
#include <cmath>

#include "body/joint_names.h"
#include "body/lbs.h"
#include "body/rest_skeleton.h"
#include "body/rotation.h"
#include "core/error.h"

namespace haha {

namespace {

using V3 = Vec3<double>;
using M3 = Mat3<double>;

// The rotation of an affine map (its columns made orthonormal: scale and shear dropped).
M3 rotation_of(const Affine& a) {
  V3 x = a.m.col(0), y = a.m.col(1);
  const double nx = norm(x);
  if (!(nx > 0)) return M3::identity();
  x = x / nx;
  y = y - dot(y, x) * x;
  const double ny = norm(y);
  if (!(ny > 0)) return M3::identity();
  y = y / ny;
  return M3::from_cols(x, y, cross(x, y));
}

// The signed axis nearest to v.
V3 snapped(const V3& v) {
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(v[i]) > std::abs(v[k])) k = i;
  V3 e(0, 0, 0);
  e[k] = v[k] < 0 ? -1 : 1;
  return e;
}

// The first joint of `list` the match binds, or -1.
int first_bound(const BoneMatch& m, std::initializer_list<int> list) {
  for (int j : list)
    if (m.node_of[size_t(j)] >= 0) return j;
  return -1;
}

// A: the rig's world to haha's, from the rig's rest (rows: its left, up and forward axes).
M3 world_alignment(const RigAnimation& rig, const BoneMatch& m, const std::vector<Affine>& rest) {
  const auto pos = [&](int j) { return rest[size_t(m.node_of[size_t(j)])].t; };
  V3 left(0, 0, 0);
  for (const auto& [l, r] : {std::pair{1, 2}, std::pair{16, 17}, std::pair{13, 14}})
    if (m.node_of[size_t(l)] >= 0 && m.node_of[size_t(r)] >= 0 && norm(pos(l) - pos(r)) > 0) {
      left = pos(l) - pos(r);
      break;
    }
  const int top = first_bound(m, {15, 12, 9, 6, 3});
  if (norm(left) == 0 || top < 0 || !(norm(pos(top) - pos(0)) > 0))
    fail(rig.source, "map '" + m.map + "' binds no left-right pair (hips, shoulders) or no joint above the pelvis: the rig's axes are unknown");
  const V3 l = snapped(left), u = snapped(pos(top) - pos(0));
  if (std::abs(dot(l, u)) > 0.5) fail(rig.source, "the rig's rest pose has its left and up along one axis");
  const V3 f = cross(l, u);
  M3 A;
  for (int c = 0; c < 3; ++c) A.a[0][c] = l[c], A.a[1][c] = u[c], A.a[2][c] = f[c];
  return A;
}

double leg_length(const std::vector<V3>& p, int hip, int knee, int ankle) { return norm(p[size_t(hip)] - p[size_t(knee)]) + norm(p[size_t(knee)] - p[size_t(ankle)]); }

// Body leg length over the rig's (a torso length when the rig has no bound leg).
double leg_scale(const BoneMatch& m, const std::vector<V3>& rig_pos, const RestSkeleton& body) {
  for (const auto& [h, k, a] : {std::tuple{1, 4, 7}, std::tuple{2, 5, 8}})
    if (m.node_of[size_t(h)] >= 0 && m.node_of[size_t(k)] >= 0 && m.node_of[size_t(a)] >= 0) {
      const double r = leg_length(rig_pos, h, k, a);
      if (r > 0) return leg_length(body.joints, h, k, a) / r;
    }
  const int top = first_bound(m, {12, 15, 9});
  const double r = top < 0 ? 0 : norm(rig_pos[size_t(top)] - rig_pos[0]);
  return r > 0 ? norm(body.joints[size_t(top)] - body.joints[0]) / r : 1.0;
}

// RetargetReport::rest_torso_deg (rig_pos already turned by A).
double rest_torso_angle(const BoneMatch& m, const std::vector<V3>& rig_pos, const RestSkeleton& body) {
  const int top = first_bound(m, {12, 15});
  if (top < 0) return NAN;
  const V3 a = rig_pos[size_t(top)] - rig_pos[0], b = body.joints[size_t(top)] - body.joints[0];
  if (!(norm(a) > 0) || !(norm(b) > 0)) return NAN;
  return std::acos(std::clamp(dot(a, b) / (norm(a) * norm(b)), -1.0, 1.0)) * 180 / M_PI;
}

// Which joints take a rest offset from their bone's direction: the limbs (thighs, shins,
// upper arms, forearms, hands, fingers), whose rest directions differ by pose (an A-pose).
// The torso, collars, neck and head keep SMPL-X's rest: their directions differ between
// skeletons by build (a straight spine, an upright neck), and aligning them would tip the
// head back. Ankles and feet follow their shins.
enum class Rest { align, torso, follow };
Rest rest_kind(int j) {
  switch (j) {
    case 1: case 2: case 4: case 5: case 16: case 17: case 18: case 19: case 20: case 21: return Rest::align;
    case 7: case 8: case 10: case 11: return Rest::follow;
    default: return j >= kLeftHandFirst ? Rest::align : Rest::torso;
  }
}

// C_j of every joint (the header's formula).
std::vector<M3> rest_offsets(const BoneMatch& m, const std::vector<V3>& rig_pos, const RestSkeleton& body) {
  std::vector<M3> C(size_t(kNumJoints), M3::identity());
  for (int j = 0; j < kNumJoints; ++j) {
    const Rest kind = rest_kind(j);
    if (kind == Rest::torso) continue;
    const int p = body.parents[size_t(j)], c = kSmplxBoneChild[j];
    C[size_t(j)] = C[size_t(p)];  // limbs hang from the torso: p >= 0
    if (kind == Rest::follow || c < 0 || m.node_of[size_t(j)] < 0 || m.node_of[size_t(c)] < 0) continue;
    const V3 ds = rig_pos[size_t(c)] - rig_pos[size_t(j)], dt = body.joints[size_t(c)] - body.joints[size_t(j)];
    // The parent's offset first, then the smallest turn that still remains: a chain turned
    // rigidly at its root (an A-pose arm, thumb and all) takes that one turn, twist included.
    const V3 dp = C[size_t(p)] * dt;
    if (norm(ds) > 0 && norm(dp) > 0) C[size_t(j)] = rotation_between(dp / norm(dp), ds / norm(ds)) * C[size_t(p)];
  }
  return C;
}

}  // namespace

M3 rotation_between(const V3& a, const V3& b) {
  const V3 v = cross(a, b);
  const double c = dot(a, b);
  if (c < -1 + 1e-12) {  // opposite: half a turn about any axis perpendicular to a
    V3 axis = cross(a, std::abs(a.x) < 0.9 ? V3(1, 0, 0) : V3(0, 1, 0));
    axis = axis / norm(axis);
    return 2.0 * outer(axis, axis) + (-1.0) * M3::identity();
  }
  const M3 K = skew(v);
  return M3::identity() + K + (1 / (1 + c)) * (K * K);
}

Motion retarget_rig(const RigAnimation& rig, const BoneMatch& m, const BodyModel& body, const RetargetOptions& o,
                    RetargetReport* report) {
  if (m.node_of.size() != size_t(kNumJoints) || m.node_of[0] < 0)
    fail(rig.source, "map '" + m.map + "' binds no bone to the pelvis (" + std::to_string(m.matched) + " joints matched): give --map MAP.json");
  if (rig.frames.empty()) fail(rig.source, "no frames");
  const RestSkeleton skel = rest_skeleton(body);
  const std::vector<Affine> rest = world_transforms(rig, rig.rest);
  const M3 A = world_alignment(rig, m, rest), At = transpose(A);
  std::vector<V3> rig_pos(kNumJoints);
  std::vector<M3> rest_rot(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j)
    if (m.node_of[size_t(j)] >= 0) {
      const Affine& w = rest[size_t(m.node_of[size_t(j)])];
      rig_pos[size_t(j)] = A * w.t;
      rest_rot[size_t(j)] = transpose(rotation_of(w));
    }
  RetargetReport rep;
  rep.alignment = A;
  rep.scale = leg_scale(m, rig_pos, skel);
  rep.rest_torso_deg = rest_torso_angle(m, rig_pos, skel);
  const std::vector<M3> C = rest_offsets(m, rig_pos, skel);
  Motion out;
  out.source = rig.source;
  out.fps = rig.fps;
  std::vector<V3> pelvis;
  double ground = INFINITY;  // the rig's lowest ankle over the clip (aligned world)
  const int ankles[2] = {m.node_of[7], m.node_of[8]};
  for (const std::vector<Affine>& local : rig.frames) {
    const std::vector<Affine> w = world_transforms(rig, local);
    std::vector<M3> G(kNumJoints);
    SmplxParams p;
    for (int j = 0; j < kNumJoints; ++j) {
      const int n = m.node_of[size_t(j)], par = skel.parents[size_t(j)];
      G[size_t(j)] = n < 0 ? G[size_t(par)] : A * rotation_of(w[size_t(n)]) * rest_rot[size_t(j)] * At * C[size_t(j)];
      const V3 aa = matrix_to_axis_angle(par < 0 ? G[size_t(j)] : transpose(G[size_t(par)]) * G[size_t(j)]);
      for (int c = 0; c < 3; ++c) p.pose[size_t(3 * j + c)] = float(aa[c]);
    }
    pelvis.push_back(A * w[size_t(m.node_of[0])].t);
    for (int a : ankles)
      if (a >= 0) ground = std::min(ground, (A * w[size_t(a)].t).y);
    out.frames.push_back(p);
  }
  // Standing height: the rig's lowest ankle at the body's rest ankle; without ankles the
  // rest pelvis heights are matched.
  const double body_ankle = std::min(skel.joints[7].y, skel.joints[8].y);
  const double ref_rig = std::isfinite(ground) ? ground : rig_pos[0].y, ref_body = std::isfinite(ground) ? body_ankle : skel.joints[0].y;
  for (size_t t = 0; t < out.frames.size(); ++t) {
    const V3 P(rep.scale * pelvis[t].x, ref_body + rep.scale * (pelvis[t].y - ref_rig), rep.scale * pelvis[t].z);
    const V3 tr = P - skel.joints[0];
    out.frames[t].transl = {float(tr.x), float(tr.y), float(tr.z)};
  }
  if (o.lock_feet) {
    // A rig without toes stands on its ankles: its feet would otherwise hold their rest angle
    // and the toe joints skate where the rig's ankles stand.
    FootLockParams lock = o.contacts;
    if (m.node_of[10] < 0 || m.node_of[11] < 0) lock.joints[0] = 7, lock.joints[1] = 8;
    rep.contacts = lock_feet(Lbs<double>(body), out.frames, out.fps, lock);
  }
  for (int j = 0; j < 22; ++j)
    if (m.node_of[size_t(j)] < 0) rep.at_rest.push_back(j);
  if (report) *report = rep;
  return out;
}

}  // namespace haha
