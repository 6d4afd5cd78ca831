#include "app/motion_from_fit.h"

#include "app/foot_lock.h"

#include <algorithm>
#include <cmath>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/error.h"
#include "io/npy.h"

namespace haha {

namespace {

using V3 = Vec3<double>;
using Q = Quat<double>;

V3 joint_aa(const SmplxParams& p, int j) { return V3(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)]); }
void set_aa(SmplxParams& p, int j, const V3& w) {
  for (int c = 0; c < 3; ++c) p.pose[size_t(3 * j + c)] = float(w[c]);
}

// A body's rest pelvis and the height of its lowest rest vertex (its soles).
struct Rest {
  V3 pelvis;
  double sole = 0;
};
Rest rest_of(const Lbs<double>& lbs, const BodyModel& b, const std::vector<float>& betas) {
  SmplxParams p;
  p.betas = betas;
  std::vector<double> verts(size_t(b.num_verts) * 3), joints(size_t(kNumJoints) * 3);
  lbs.forward(p, verts.data(), joints.data(), nullptr);
  Rest r{V3(joints[0], joints[1], joints[2]), INFINITY};
  for (int v = 0; v < b.num_verts; ++v) r.sole = std::min(r.sole, verts[size_t(v) * 3 + 1]);
  return r;
}

// The kept frames from the first to the last, gaps filled by slerp / lerp between the kept
// neighbours.
std::vector<SmplxParams> bridged(const FitVideoResult& fit, MotionFromFitReport& rep, int n) {
  const std::vector<int>& k = fit.kept;
  std::vector<SmplxParams> out;
  for (size_t i = 0; i + 1 < k.size(); ++i) {
    const SmplxParams &a = fit.params[i], &b = fit.params[i + 1];
    for (int f = k[i]; f < k[i + 1]; ++f) {
      const double s = double(f - k[i]) / double(k[i + 1] - k[i]);
      SmplxParams p = a;
      for (int j = 0; j < kNumJoints && s > 0; ++j)
        set_aa(p, j, quat_to_axis_angle(slerp_shortest(axis_angle_to_quat(joint_aa(a, j)), axis_angle_to_quat(joint_aa(b, j)), s)));
      for (int c = 0; c < 3; ++c) p.transl[size_t(c)] = float(a.transl[size_t(c)] + s * (b.transl[size_t(c)] - a.transl[size_t(c)]));
      rep.bridged += f != k[i];
      out.push_back(p);
    }
  }
  out.push_back(fit.params.back());
  rep.cut = n - (k.back() - k.front() + 1);
  return out;
}

// Camera (OpenCV: y down, z forward) to haha's Y-up world facing the camera: a half turn
// about x. Returns each frame's pelvis position; the root rotation is turned in place.
std::vector<V3> to_world(std::vector<SmplxParams>& frames, const V3& subject_pelvis) {
  Mat3<double> C = Mat3<double>::identity();
  C.a[1][1] = C.a[2][2] = -1;
  std::vector<V3> pelvis;
  for (SmplxParams& p : frames) {
    set_aa(p, 0, matrix_to_axis_angle(C * rodrigues(joint_aa(p, 0))));
    pelvis.push_back(C * (subject_pelvis + V3(p.transl[0], p.transl[1], p.transl[2])));
  }
  return pelvis;
}

void smooth(std::vector<SmplxParams>& frames, std::vector<V3>& pelvis, double fps, const OneEuroParams& f) {
  for (int j = 0; j < kNumJoints; ++j) {
    std::vector<Q> q;
    for (const SmplxParams& p : frames) q.push_back(axis_angle_to_quat(joint_aa(p, j)));
    q = one_euro(q, fps, f);
    for (size_t t = 0; t < frames.size(); ++t) set_aa(frames[t], j, quat_to_axis_angle(q[t]));
  }
  pelvis = one_euro(pelvis, fps, f);
}

// Median over frames of the subject's lowest posed point: where the ground is.
double ground_height(const Lbs<double>& lbs, const BodyModel& b, const std::vector<SmplxParams>& frames,
                     const std::vector<V3>& pelvis, const V3& rest_pelvis) {
  std::vector<double> verts(size_t(b.num_verts) * 3), joints(size_t(kNumJoints) * 3), lowest;
  for (size_t t = 0; t < frames.size(); ++t) {
    SmplxParams p = frames[t];
    const V3 tr = pelvis[t] - rest_pelvis;
    p.transl = {float(tr.x), float(tr.y), float(tr.z)};
    lbs.forward(p, verts.data(), joints.data(), nullptr);
    double y = INFINITY;
    for (int v = 0; v < b.num_verts; ++v) y = std::min(y, verts[size_t(v) * 3 + 1]);
    lowest.push_back(y);
  }
  std::nth_element(lowest.begin(), lowest.begin() + long(lowest.size() / 2), lowest.end());
  return lowest[lowest.size() / 2];
}

}  // namespace

Motion motion_from_fit(const FitVideoResult& fit, int n, double fps, const BodyModel& subject, const BodyModel& player,
                       const MotionFromFitOptions& o, MotionFromFitReport* report) {
  if (fit.kept.size() < 2 || fit.params.size() != fit.kept.size()) fail("fit", "fewer than two frames were fitted: no motion");
  if (!(fps > 0)) fail("fit", "frame rate must be positive");
  MotionFromFitReport rep;
  std::vector<SmplxParams> frames = bridged(fit, rep, n);
  const Lbs<double> subject_lbs(subject), player_lbs(player);
  const std::vector<float> betas = fit.params.front().betas;
  const Rest rs = rest_of(subject_lbs, subject, betas), rp = rest_of(player_lbs, player, {});
  std::vector<V3> pelvis = to_world(frames, rs.pelvis);
  smooth(frames, pelvis, fps, o.filter);
  for (SmplxParams& p : frames) p.betas = betas;
  const double ground = ground_height(subject_lbs, subject, frames, pelvis, rs.pelvis);
  rep.scale = (rp.pelvis.y - rp.sole) / (rs.pelvis.y - rs.sole);
  const V3 start = pelvis.front();
  for (size_t t = 0; t < frames.size(); ++t) {
    // The player's pelvis: the subject's path about its start, scaled, over the player's soles.
    const V3 P(rep.scale * (pelvis[t].x - start.x), rp.sole + rep.scale * (pelvis[t].y - ground), rep.scale * (pelvis[t].z - start.z));
    const V3 tr = P - rp.pelvis;
    frames[t].transl = {float(tr.x), float(tr.y), float(tr.z)};
    frames[t].betas.clear();
  }
  if (o.lock_feet) rep.contacts = lock_feet(player_lbs, frames, fps, {o.contact_speed, o.contact_height, o.min_contact_frames});
  rep.frames = int(frames.size());
  if (report) *report = rep;
  Motion m;
  m.frames = std::move(frames);
  m.fps = fps;
  return m;
}

void write_motion_npz(const Motion& m, const std::string& path) {
  const int64_t T = int64_t(m.frames.size());
  std::vector<float> poses, trans;
  for (const SmplxParams& p : m.frames) {
    poses.insert(poses.end(), p.pose.begin(), p.pose.end());
    trans.insert(trans.end(), p.transl.begin(), p.transl.end());
  }
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, kNumPoseValues}));
  z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{m.fps}, {}));
  z.set("up", NpyArray::from(std::vector<float>{0, 1, 0}, {3}));  // haha's Y-up world
  z.write(path);
}

}  // namespace haha
