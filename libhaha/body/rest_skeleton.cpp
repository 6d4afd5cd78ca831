#include "body/rest_skeleton.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "body/joint_names.h"
#include "body/lbs.h"

namespace haha {

int smplx_joint_index(const char* name) {
  for (int j = 0; j < kNumJoints; ++j)
    if (std::strcmp(name, kSmplxJointNames[j]) == 0) return j;
  if (std::strcmp(name, "left_eye_smplhf") == 0) return kLeftEye;
  if (std::strcmp(name, "right_eye_smplhf") == 0) return kRightEye;
  return -1;
}

RestSkeleton rest_skeleton(const BodyModel& body) {
  const Lbs<double> lbs(body);
  std::vector<double> verts(size_t(body.num_verts) * 3), joints(size_t(kNumJoints) * 3);
  lbs.forward(SmplxParams{}, verts.data(), joints.data(), nullptr);
  RestSkeleton s;
  for (int j = 0; j < kNumJoints; ++j) s.joints.emplace_back(joints[size_t(3 * j)], joints[size_t(3 * j + 1)], joints[size_t(3 * j + 2)]);
  s.parents.assign(body.parents.begin(), body.parents.end());
  s.parents[0] = -1;
  s.sole = INFINITY;
  for (int v = 0; v < body.num_body_verts(); ++v) s.sole = std::min(s.sole, verts[size_t(v) * 3 + 1]);
  return s;
}

}  // namespace haha
