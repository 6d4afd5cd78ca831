// Which faces stretch as the arms move (train/face_stretch.h), on the procedural body: the
// faces skinned to the shoulders and upper arms stretch, the legs' and the head's do not,
// and the result is finite and non-negative everywhere.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "train/face_stretch.h"
#include "support/low_body.h"

namespace haha {
namespace {

// The joint with the largest skinning weight of a face's first vertex.
int main_joint(const BodyModel& b, int f) {
  const int v = b.faces[3 * size_t(f)];
  const float* w = &b.weights[size_t(v) * kNumJoints];
  return int(std::max_element(w, w + kNumJoints) - w);
}

TEST(FaceStretch, ShouldersStretchLegsAndHeadDoNot) {
  const BodyModel& b = test::low_body();
  const std::vector<float> s = face_arm_stretch(b, {}, 0.05f);
  ASSERT_EQ(s.size(), size_t(b.num_faces));
  float shoulders = 0, legs = 0, head = 0;
  for (int f = 0; f < b.num_faces; ++f) {
    ASSERT_TRUE(std::isfinite(s[size_t(f)]) && s[size_t(f)] >= 0) << "face " << f;
    const int j = main_joint(b, f);
    // SMPL-X: 13/14 collars, 16/17 shoulders; 1/2 hips, 4/5 knees, 7/8 ankles; 12 neck, 15 head.
    if (j == 13 || j == 14 || j == 16 || j == 17) shoulders = std::max(shoulders, s[size_t(f)]);
    if (j == 1 || j == 2 || j == 4 || j == 5 || j == 7 || j == 8) legs = std::max(legs, s[size_t(f)]);
    if (j == 15) head = std::max(head, s[size_t(f)]);
  }
  // Raising the arms from 65 degrees below to 60 above horizontal stretches the armpit
  // faces by far more than 20 % (log 1.2 = 0.18); legs and head are not moved at all.
  EXPECT_GT(shoulders, 0.18f);
  EXPECT_LT(legs, 1e-4f);
  EXPECT_LT(head, 1e-4f);
}

}  // namespace
}  // namespace haha
