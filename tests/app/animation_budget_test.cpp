// What a 10 s, 30 fps animation adds to a .glb with the default quantization (16-bit
// rotations): haha's own motions (`haha motion --kind ...`) stay within 60 KB, and the
// added bytes follow from what is stored (the moving tracks' keys and the JSON that
// describes them), so a motion moving every body joint is measured and printed too, with
// the default keyframe reduction (format/animation_pack.h) and with every key kept.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "format/avatar_pack.h"
#include "support/format_test_avatar.h"
#include "synth/demo_motion.h"

namespace haha {
namespace {

constexpr int kFrames = 300;  // 10 s
constexpr double kFps = 30;

size_t added_bytes(const Motion& m, int bits = kDefaultAnimationRotationBits, double tolerance = kDefaultAnimationTolerance) {
  const Avatar a = test::make_test_avatar(40, 2, 8, 8);
  PackOptions with;
  with.animations.push_back({"clip", m, tolerance});
  with.animation_bits = bits;
  return pack_avatar(a, with).size() - pack_avatar(a, PackOptions{}).size();
}

Motion demo(const std::string& kind) {
  Motion m;
  m.fps = kFps;
  m.source = kind;
  for (int k = 0; k < kFrames; ++k) {
    SmplxParams p;
    // Two loops of the procedural motion over the clip, as `haha motion --frames 150` twice.
    const std::vector<float> pose = demo_motion_pose(kind, std::fmod(2.0 * k / kFrames, 1.0));
    std::copy(pose.begin(), pose.end(), p.pose.begin());
    m.frames.push_back(p);
  }
  return m;
}

TEST(AnimationBudget, HahasOwnMotionsAddAtMostSixtyKilobytes) {
  for (const char* kind : {"walk", "wave", "turn"}) {
    const size_t b = added_bytes(demo(kind)), every = added_bytes(demo(kind), 16, 0.0);
    std::printf("%s, 10 s at 30 fps: %zu B added (%zu B keeping every key)\n", kind, b, every);
    EXPECT_LE(b, 60000u) << kind;
    EXPECT_LE(b, every) << kind << ": the reduction must not cost bytes";
  }
}

TEST(AnimationBudget, EveryBodyJointMovingCostsItsKeys) {
  Motion m;
  m.fps = kFps;
  for (int k = 0; k < kFrames; ++k) {
    SmplxParams p;
    for (int j = 0; j <= 21; ++j)
      for (int c = 0; c < 3; ++c) p.pose[size_t(3 * j + c)] = float(0.5 * std::sin(0.3 * (j + 1) * k / kFps + c));
    p.transl = {float(0.01 * k), 0.0f, 0.0f};
    m.frames.push_back(p);
  }
  const size_t b16 = added_bytes(m), b8 = added_bytes(m, 8), every16 = added_bytes(m, 16, 0.0);
  std::printf("all 22 body joints + root translation, 10 s at 30 fps: %zu B added (16-bit, default tolerance), "
              "%zu B (8-bit), %zu B (16-bit, every key)\n", b16, b8, every16);
  EXPECT_LE(b16, 60000u) << "the budget with the default quantization and keyframe reduction";
  // Every key kept (tolerance 0). Binary: 22 rotation tracks x 300 keys x 4 components, 300
  // translations, 300 shared key times (the still joints rest: no track); what is left is the JSON.
  const size_t keys16 = 22 * kFrames * 8 + kFrames * 12 + kFrames * 4;
  EXPECT_GE(every16, keys16);
  EXPECT_LE(every16 - keys16, 12000u) << "JSON per track grew";
  EXPECT_LT(b16, every16) << "the reduction dropped nothing";
  EXPECT_LT(b8, b16);
}

// A jittery motion (every joint off by up to 1.5e-3 rad at random each frame, as a raw per-frame
// fit can be): the reduction keeps most keys, each track different ones, and then must keep the shared full input
// instead of paying key times per track.
TEST(AnimationBudget, JitterCostsNoMoreThanEveryKey) {
  Motion m;
  m.fps = kFps;
  uint32_t state = 12345;
  auto noise = [&] { state = state * 1664525u + 1013904223u; return (state >> 8) / double(1 << 24) - 0.5; };
  for (int k = 0; k < kFrames; ++k) {
    SmplxParams p;
    for (int j = 0; j <= 21; ++j)
      for (int c = 0; c < 3; ++c) p.pose[size_t(3 * j + c)] = float(0.3 * std::sin(0.5 * k / kFps + j) + 0.003 * noise());
    m.frames.push_back(p);
  }
  const size_t b = added_bytes(m), every = added_bytes(m, 16, 0.0);
  std::printf("jittery motion, 22 joints, 10 s at 30 fps: %zu B added (%zu B keeping every key)\n", b, every);
  EXPECT_LE(b, every);
}

}  // namespace
}  // namespace haha
