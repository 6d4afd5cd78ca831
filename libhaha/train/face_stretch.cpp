#include "train/face_stretch.h"

#include <algorithm>
#include <cmath>

#include "body/face_frames.h"
#include "body/lbs.h"
#include "body/smplx_params.h"

namespace haha {

std::vector<float> face_arm_stretch(const BodyModel& body, const std::vector<float>& betas, float face_scale_divisor) {
  // Shoulder joints 16 (left, +X) and 17 (right). From the T-pose, R_z(-a) lowers the left
  // arm and R_z(+a) the right one; R_y(-v) brings the left arm forward, R_y(+v) the right.
  constexpr int kLeftShoulder = 16, kRightShoulder = 17;
  struct ArmPose {
    int axis;
    float left;  // the right arm mirrors it
  };
  const ArmPose poses[] = {{2, -1.134f}, {2, 0.0f}, {2, 1.047f}, {1, -1.571f}};
  const Lbs<float> lbs(body);
  std::vector<float> verts(3 * size_t(body.num_verts));
  const int F = body.num_faces;
  std::vector<float> kmin(size_t(F), INFINITY), kmax(size_t(F), 0.0f);
  for (const ArmPose& a : poses) {
    SmplxParams p;
    p.betas = betas;
    p.pose[3 * kLeftShoulder + a.axis] = a.left;
    p.pose[3 * kRightShoulder + a.axis] = -a.left;
    lbs.forward(p, verts.data(), nullptr, nullptr);
    for (int f = 0; f < F; ++f) {
      Vec3f v[3];
      for (int c = 0; c < 3; ++c) {
        const float* x = &verts[3 * size_t(body.faces[3 * size_t(f) + c])];
        v[c] = Vec3f(x[0], x[1], x[2]);
      }
      const float k = face_frame(v[0], v[1], v[2], face_scale_divisor).k;
      kmin[size_t(f)] = std::min(kmin[size_t(f)], k);
      kmax[size_t(f)] = std::max(kmax[size_t(f)], k);
    }
  }
  std::vector<float> stretch(size_t(F), 0.0f);
  for (int f = 0; f < F; ++f)
    if (kmin[size_t(f)] > 0 && std::isfinite(kmax[size_t(f)])) stretch[size_t(f)] = std::log(kmax[size_t(f)] / kmin[size_t(f)]);
  return stretch;
}

}  // namespace haha
