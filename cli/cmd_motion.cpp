// `haha motion`: writes a short procedural SMPL-X motion as an AMASS-style .npz (poses
// (T, 165), trans (T, 3), mocap_frame_rate, up = (0, 1, 0): haha's Y-up world, unlike
// AMASS's Z-up) for `haha render --motion`. The demo uses it to
// repose a trained avatar with poses it never saw in training (the synthetic subject trains
// on turning in place with lowered arms).
//
// Rotations are SMPL-X local rotations in the rest (T-pose) frame: arms along +-X, legs
// along -Y, body facing +Z. R_z(-a) lowers the left arm, R_z(+a) the right one; R_x(-b)
// swings a thigh or a hanging arm forward; R_x(+k) bends a knee; R_z(+-c) lifts the forearm
// of a T-pose arm (the same facts as data/synth_motion.cpp).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/rotation.h"
#include "command.h"
#include "core/error.h"
#include "io/npy.h"

namespace {

using M3 = haha::Mat3<double>;
using V3 = haha::Vec3<double>;
constexpr double kTau = 6.283185307179586;

M3 Rx(double a) { return haha::rodrigues(V3(a, 0, 0)); }
M3 Ry(double a) { return haha::rodrigues(V3(0, a, 0)); }
M3 Rz(double a) { return haha::rodrigues(V3(0, 0, a)); }

void set_joint(std::vector<float>& pose, int j, const M3& R) {
  const V3 w = haha::matrix_to_axis_angle(R);
  for (int c = 0; c < 3; ++c) pose[size_t(3 * j + c)] = float(w[c]);
}

// One frame at phase s in [0, 1) (the motion loops).
std::vector<float> motion_frame(const std::string& kind, double s) {
  std::vector<float> pose(haha::kNumPoseValues, 0.0f);
  const double c1 = std::sin(kTau * s), c2 = std::sin(2 * kTau * s), c4 = std::sin(4 * kTau * s);
  if (kind == "wave") {
    // Facing the camera, swaying a little; the right arm raised with the forearm up,
    // waving from the elbow; the left arm hanging. Looks to both sides once.
    set_joint(pose, haha::kGlobalOrient, Ry(0.5 * c1));
    set_joint(pose, 3, Rz(0.06 * c2));
    set_joint(pose, 15, Ry(0.25 * c1) * Rx(0.08 * c2));
    set_joint(pose, 16, Rx(-0.15) * Rz(-1.25));               // left arm down
    set_joint(pose, 18, Ry(-0.3));  // slight elbow bend
    set_joint(pose, 17, Rz(-0.35));                           // right arm a little above horizontal
    set_joint(pose, 19, Rz(-1.4 + 0.45 * c4));                // forearm up, waving
    set_joint(pose, 21, Rz(0.25 * c4));
  } else if (kind == "walk") {
    // Walking in place, two strides per loop, turning a quarter each way.
    set_joint(pose, haha::kGlobalOrient, Ry(0.8 * c1));
    const double stride = 0.45 * c2;
    set_joint(pose, 1, Rx(-stride));
    set_joint(pose, 2, Rx(stride));
    set_joint(pose, 4, Rx(0.15 + 0.55 * std::max(0.0, c2)));
    set_joint(pose, 5, Rx(0.15 + 0.55 * std::max(0.0, -c2)));
    set_joint(pose, 16, Rx(stride) * Rz(-1.3));
    set_joint(pose, 17, Rx(-stride) * Rz(1.3));
    set_joint(pose, 18, Ry(-0.4));
    set_joint(pose, 19, Ry(0.4));
    set_joint(pose, 3, Ry(-0.1 * c2));
  } else if (kind == "turn") {
    // A full turn with the arms half lowered and the knees slightly bent.
    set_joint(pose, haha::kGlobalOrient, Ry(kTau * s));
    set_joint(pose, 16, Rz(-0.7));
    set_joint(pose, 17, Rz(0.7));
    set_joint(pose, 18, Rz(0.8));
    set_joint(pose, 19, Rz(-0.8));
    for (int side = 0; side < 2; ++side) {
      set_joint(pose, 1 + side, Rx(-0.3));
      set_joint(pose, 4 + side, Rx(0.6));
      set_joint(pose, 7 + side, Rx(-0.3));
    }
  } else {
    haha::fail("--kind", "unknown motion '" + kind + "' (wave, walk, turn)");
  }
  return pose;
}

}  // namespace

HAHA_COMMAND(motion) {
  struct Opts {
    std::string out, kind = "wave";
    int frames = 48;
    double fps = 24;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("motion", "Write a short procedural SMPL-X motion (AMASS-style .npz) for haha render");
  sub->add_option("--out", o->out, "output .npz (poses (T,165), trans (T,3), mocap_frame_rate)")->required();
  sub->add_option("--kind", o->kind, "wave, walk or turn")->capture_default_str();
  sub->add_option("--frames", o->frames, "number of frames (one loop of the motion)")->capture_default_str();
  sub->add_option("--fps", o->fps, "frame rate stored in the file")->capture_default_str();
  sub->callback([o] {
    if (o->frames < 1 || o->frames > 100000) haha::fail("--frames", "must be in 1..100000");
    if (!(o->fps > 0 && o->fps <= 1000)) haha::fail("--fps", "must be in (0, 1000]");
    motion_frame(o->kind, 0.0);  // rejects an unknown kind before any work
    const size_t T = size_t(o->frames);
    std::vector<float> poses(T * haha::kNumPoseValues), trans(T * 3, 0.0f);
    for (size_t t = 0; t < T; ++t) {
      const std::vector<float> p = motion_frame(o->kind, double(t) / double(T));
      std::copy(p.begin(), p.end(), poses.begin() + long(t * haha::kNumPoseValues));
    }
    haha::Npz z;
    z.set("poses", haha::NpyArray::from(poses, {int64_t(T), haha::kNumPoseValues}));
    z.set("trans", haha::NpyArray::from(trans, {int64_t(T), 3}));
    z.set("mocap_frame_rate", haha::NpyArray::from(std::vector<double>{o->fps}, {}));
    // Written in haha's Y-up world; without `up` readers take AMASS's Z-up (io/motion.h).
    z.set("up", haha::NpyArray::from(std::vector<float>{0, 1, 0}, {3}));
    z.write(o->out);
    std::printf("%s: %zu frames of '%s' at %g fps\n", o->out.c_str(), T, o->kind.c_str(), o->fps);
  });
}
