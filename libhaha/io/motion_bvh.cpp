#include "io/motion_bvh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "body/joint_names.h"
#include "body/rotation.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {

namespace {

using V3 = Vec3<double>;
constexpr double kCm = 100, kDeg = 180 / M_PI;

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6f", std::abs(v) < 5e-7 ? 0.0 : v);
  return b;
}

void hierarchy(const RestSkeleton& rest, int j, int depth, std::string& out) {
  const std::string pad(size_t(2 * depth), ' ');
  const int p = rest.parents[size_t(j)];
  const V3 off = p < 0 ? V3(0, 0, 0) : kCm * (rest.joints[size_t(j)] - rest.joints[size_t(p)]);
  out += pad + (p < 0 ? "ROOT " : "JOINT ") + kSmplxJointNames[j] + "\n" + pad + "{\n";
  out += pad + "  OFFSET " + num(off.x) + " " + num(off.y) + " " + num(off.z) + "\n";
  out += pad + (p < 0 ? "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
                      : "  CHANNELS 3 Zrotation Yrotation Xrotation\n");
  bool leaf = true;
  for (int c = 0; c < kNumJoints; ++c)
    if (rest.parents[size_t(c)] == j) leaf = false, hierarchy(rest, c, depth + 1, out);
  if (leaf) {  // BVH needs a bone end; half the joint's own bone carries on
    const V3 end = 0.5 * off;
    out += pad + "  End Site\n" + pad + "  {\n" + pad + "    OFFSET " + num(end.x) + " " + num(end.y) + " " + num(end.z) + "\n" + pad + "  }\n";
  }
  out += pad + "}\n";
}

// Joints in the order hierarchy() writes them (depth first, children by index).
void order(const RestSkeleton& rest, int j, std::vector<int>& out) {
  out.push_back(j);
  for (int c = 0; c < kNumJoints; ++c)
    if (rest.parents[size_t(c)] == j) order(rest, c, out);
}

}  // namespace

Mat3<double> euler_zyx_matrix(const V3& zyx) {
  const double cz = std::cos(zyx.x), sz = std::sin(zyx.x), cy = std::cos(zyx.y), sy = std::sin(zyx.y);
  const double cx = std::cos(zyx.z), sx = std::sin(zyx.z);
  Mat3<double> Rz = Mat3<double>::identity(), Ry = Rz, Rx = Rz;
  Rz.a[0][0] = cz, Rz.a[0][1] = -sz, Rz.a[1][0] = sz, Rz.a[1][1] = cz;
  Ry.a[0][0] = cy, Ry.a[0][2] = sy, Ry.a[2][0] = -sy, Ry.a[2][2] = cy;
  Rx.a[1][1] = cx, Rx.a[1][2] = -sx, Rx.a[2][1] = sx, Rx.a[2][2] = cx;
  return Rz * Ry * Rx;
}

V3 matrix_to_euler_zyx(const Mat3<double>& R) {
  const double sy = std::clamp(-R.a[2][0], -1.0, 1.0);
  const double y = std::asin(sy);
  if (std::abs(sy) > 1 - 1e-12)  // gimbal lock: only z - x (or z + x) is defined; put it in z
    return V3(std::atan2(-R.a[0][1], R.a[1][1]), y, 0);
  return V3(std::atan2(R.a[1][0], R.a[0][0]), y, std::atan2(R.a[2][1], R.a[2][2]));
}

std::string motion_bvh_text(const Motion& m, const RestSkeleton& rest) {
  if (rest.joints.size() != size_t(kNumJoints) || rest.parents.size() != size_t(kNumJoints))
    fail(m.source.empty() ? "bvh" : m.source, "the body's skeleton has no 55 joints");
  if (m.frames.empty()) fail(m.source.empty() ? "bvh" : m.source, "no frames");
  std::string out = "HIERARCHY\n";
  hierarchy(rest, 0, 0, out);
  std::vector<int> joints;
  order(rest, 0, joints);
  char head[96];
  std::snprintf(head, sizeof head, "MOTION\nFrames: %zu\nFrame Time: %.9f\n", m.frames.size(), 1.0 / m.fps);
  out += head;
  const V3 floor(0, rest.sole, 0);
  for (const SmplxParams& p : m.frames) {
    const V3 root = kCm * (rest.joints[0] + V3(p.transl[0], p.transl[1], p.transl[2]) - floor);
    std::string line = num(root.x) + " " + num(root.y) + " " + num(root.z);
    for (int j : joints) {
      const V3 w(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)]);
      const V3 e = kDeg * matrix_to_euler_zyx(rodrigues(w));
      line += " " + num(e.x) + " " + num(e.y) + " " + num(e.z);
    }
    out += line + "\n";
  }
  return out;
}

void write_motion_bvh(const Motion& m, const RestSkeleton& rest, const std::string& path) {
  write_text_file(path, motion_bvh_text(m, rest));
}

}  // namespace haha
