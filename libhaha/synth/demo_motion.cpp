#include "synth/demo_motion.h"

#include <algorithm>
#include <cmath>

#include "body/body_model.h"
#include "body/rotation.h"
#include "core/error.h"

namespace haha {
namespace {

using M3 = Mat3<double>;
using V3 = Vec3<double>;
constexpr double kTau = 6.283185307179586;

M3 Rx(double a) { return rodrigues(V3(a, 0, 0)); }
M3 Ry(double a) { return rodrigues(V3(0, a, 0)); }
M3 Rz(double a) { return rodrigues(V3(0, 0, a)); }

void set_joint(std::vector<float>& pose, int j, const M3& R) {
  const V3 w = matrix_to_axis_angle(R);
  for (int c = 0; c < 3; ++c) pose[size_t(3 * j + c)] = float(w[c]);
}

}  // namespace

std::vector<float> demo_motion_pose(const std::string& kind, double s) {
  std::vector<float> pose(kNumPoseValues, 0.0f);
  const double c1 = std::sin(kTau * s), c2 = std::sin(2 * kTau * s), c4 = std::sin(4 * kTau * s);
  if (kind == "wave") {
    // Facing the camera, swaying a little; the right arm raised with the forearm up,
    // waving from the elbow; the left arm hanging. Looks to both sides once.
    set_joint(pose, kGlobalOrient, Ry(0.5 * c1));
    set_joint(pose, 3, Rz(0.06 * c2));
    set_joint(pose, 15, Ry(0.25 * c1) * Rx(0.08 * c2));
    set_joint(pose, 16, Rx(-0.15) * Rz(-1.25));               // left arm down
    set_joint(pose, 18, Ry(-0.3));  // slight elbow bend
    set_joint(pose, 17, Rz(-0.35));                           // right arm a little above horizontal
    set_joint(pose, 19, Rz(-1.4 + 0.45 * c4));                // forearm up, waving
    set_joint(pose, 21, Rz(0.25 * c4));
  } else if (kind == "walk") {
    // Walking in place, two strides per loop, turning a quarter each way.
    set_joint(pose, kGlobalOrient, Ry(0.8 * c1));
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
    set_joint(pose, kGlobalOrient, Ry(kTau * s));
    set_joint(pose, 16, Rz(-0.7));
    set_joint(pose, 17, Rz(0.7));
    set_joint(pose, 18, Rz(0.8));
    set_joint(pose, 19, Rz(-0.8));
    for (int side = 0; side < 2; ++side) {
      set_joint(pose, 1 + side, Rx(-0.3));
      set_joint(pose, 4 + side, Rx(0.6));
      set_joint(pose, 7 + side, Rx(-0.3));
    }
  } else if (kind == "kick") {
    // Facing the camera, a high front kick with each leg in turn (the hip flexed to 80
    // degrees, the knee nearly straight), the arms out for balance: the hardest case for a
    // skirt skinned from the legs.
    const double right = std::max(0.0, c1), left = std::max(0.0, -c1);
    const double up_r = right * right * (3 - 2 * right), up_l = left * left * (3 - 2 * left);
    set_joint(pose, 1, Rx(-1.4 * up_l));
    set_joint(pose, 2, Rx(-1.4 * up_r));
    set_joint(pose, 4, Rx(0.25 * up_l));
    set_joint(pose, 5, Rx(0.25 * up_r));
    set_joint(pose, 3, Rx(0.15 * (up_l + up_r)));  // leaning back a little
    set_joint(pose, 16, Rz(-0.5));
    set_joint(pose, 17, Rz(0.5));
  } else {
    fail("--kind", "unknown motion '" + kind + "' (wave, walk, turn, kick)");
  }
  return pose;
}


}  // namespace haha
