// The BVH writer (io/motion_bvh.h): Euler angles that give back the rotation, and a file
// with the skeleton's joints, offsets and frames where the format puts them.
#include "io/motion_bvh.h"

#include <gtest/gtest.h>

#include <sstream>

#include "body/procedural_body.h"
#include "body/rotation.h"

namespace haha {
namespace {

using V3 = Vec3<double>;

TEST(MotionBvh, EulerZyxGivesBackTheRotation) {
  for (int i = 0; i < 200; ++i) {
    const V3 w(std::sin(1.3 * i) * 2, std::cos(0.7 * i) * 1.5, std::sin(0.31 * i + 1));
    const Mat3<double> R = rodrigues(w);
    const Mat3<double> back = euler_zyx_matrix(matrix_to_euler_zyx(R));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.a[r][c], R.a[r][c], 1e-12);
  }
  // Gimbal lock (y = +-90 degrees): still the same rotation.
  const Mat3<double> lock = euler_zyx_matrix(V3(0.4, M_PI / 2, -0.3));
  const Mat3<double> back = euler_zyx_matrix(matrix_to_euler_zyx(lock));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.a[r][c], lock.a[r][c], 1e-9);
}

TEST(MotionBvh, FileHoldsTheSkeletonAndTheFrames) {
  const RestSkeleton rest = rest_skeleton(make_procedural_body({BodyResolution::low, 0}));
  Motion m;
  m.fps = 20;
  m.frames.resize(3);
  m.frames[1].transl = {0.1f, 0.2f, 0.3f};
  m.frames[2].pose[3 * 18 + 2] = float(M_PI / 4);  // left elbow 45 degrees about z
  const std::string text = motion_bvh_text(m, rest);
  std::istringstream in(text);
  std::string line;
  int joints = 0, ends = 0;
  std::vector<std::string> frames;
  bool motion = false;
  while (std::getline(in, line)) {
    if (line.find("ROOT ") != std::string::npos || line.find("JOINT ") != std::string::npos) ++joints;
    if (line.find("End Site") != std::string::npos) ++ends;
    if (line.rfind("Frame Time:", 0) == 0) {
      EXPECT_NEAR(std::stod(line.substr(11)), 0.05, 1e-9);
      motion = true;
      continue;
    }
    if (motion) frames.push_back(line);
  }
  EXPECT_EQ(joints, kNumJoints);
  EXPECT_EQ(ends, 2 + 1 + 2 + 10);  // feet, jaw, eyes, finger tips: every joint without a child
  ASSERT_EQ(frames.size(), 3u);
  std::vector<double> f0, f1, f2;
  for (auto [s, v] : {std::pair{&frames[0], &f0}, std::pair{&frames[1], &f1}, std::pair{&frames[2], &f2}}) {
    std::istringstream vs(*s);
    double x;
    while (vs >> x) v->push_back(x);
  }
  ASSERT_EQ(f0.size(), size_t(3 + 3 * kNumJoints));
  EXPECT_NEAR(f0[1], 100 * (rest.joints[0].y - rest.sole), 1e-4);  // the floor at y = 0, centimetres
  EXPECT_NEAR(f1[0] - f0[0], 10, 1e-4);
  EXPECT_NEAR(f1[2] - f0[2], 30, 1e-4);
  double zsum = 0;
  for (size_t i = 3; i < f2.size(); i += 3) zsum += f2[i];
  EXPECT_NEAR(zsum, 45, 1e-4);  // the elbow's Zrotation, and nothing else
}

}  // namespace
}  // namespace haha
