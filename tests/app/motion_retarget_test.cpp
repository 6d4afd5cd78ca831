// Retargeting (app/motion_retarget.h) on motions whose answer is known: SMPL-X's own BVH
// (io/motion_bvh.h) read back, and synthetic rigs (tests/support/rig_fixture.h) with
// Mixamo names, an A-pose rest, an extra bone to fold and, in glTF, other bone axes.
#include <gtest/gtest.h>

#include <filesystem>

#include "app/bone_map.h"
#include "app/motion_retarget.h"
#include "app/motion_retarget_check.h"
#include "app/rig_import.h"
#include "body/joint_names.h"
#include "core/atomic_file.h"
#include "io/motion_bvh.h"
#include "support/low_body.h"
#include "support/rig_fixture.h"
#include "synth/demo_motion.h"

namespace haha {
namespace {

using test::V3;

// A looping procedural motion, walking forward 2 cm a frame and bobbing.
Motion demo(const std::string& kind, int frames) {
  Motion m;
  m.fps = 24;
  for (int t = 0; t < frames; ++t) {
    SmplxParams p;
    const std::vector<float> pose = demo_motion_pose(kind, double(t) / frames);
    std::copy(pose.begin(), pose.end(), p.pose.begin());
    p.transl = {0.01f * float(std::sin(0.3 * t)), 0.02f * float(std::sin(0.5 * t)), 0.02f * float(t)};
    m.frames.push_back(p);
  }
  return m;
}

double angle_deg(const SmplxParams& a, const SmplxParams& b, int j) {
  const auto R = [j](const SmplxParams& p) { return rodrigues(V3(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)])); };
  return norm(matrix_to_axis_angle(transpose(R(a)) * R(b))) * 180 / M_PI;
}

std::filesystem::path temp_file(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("haha-retarget-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir / name;
}

Motion retarget_file(const std::string& path, const std::string& expect_map, int expect_matched) {
  const RigAnimation rig = read_rig_animation(path);
  const BoneMatch match = choose_bone_map(builtin_bone_maps(), rig.names);
  EXPECT_EQ(match.map, expect_map);
  EXPECT_EQ(match.matched, expect_matched);
  RetargetOptions o;
  o.lock_feet = false;  // compare the root path as it was
  return retarget_rig(rig, match, test::low_body(), o);
}

TEST(MotionRetarget, SmplxBvhRoundTripWithinHalfADegree) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  for (const char* kind : {"walk", "kick"}) {
    const Motion m = demo(kind, 40);
    const std::string path = temp_file(std::string(kind) + ".bvh").string();
    write_motion_bvh(m, rest, path);
    const Motion back = retarget_file(path, "smplx", kNumJoints);
    ASSERT_EQ(back.frames.size(), m.frames.size()) << kind;
    EXPECT_NEAR(back.fps, m.fps, 1e-3);
    double worst = 0, dy_min = INFINITY, dy_max = -INFINITY;
    for (size_t t = 0; t < m.frames.size(); ++t) {
      for (int j = 0; j < kNumJoints; ++j) worst = std::max(worst, angle_deg(m.frames[t], back.frames[t], j));
      EXPECT_NEAR(back.frames[t].transl[0], m.frames[t].transl[0], 1e-3);
      EXPECT_NEAR(back.frames[t].transl[2], m.frames[t].transl[2], 1e-3);
      const double dy = back.frames[t].transl[1] - m.frames[t].transl[1];
      dy_min = std::min(dy_min, dy), dy_max = std::max(dy_max, dy);
    }
    EXPECT_LT(worst, 0.5) << kind;
    EXPECT_LT(dy_max - dy_min, 1e-3) << kind << ": the height may shift (ground from the ankles), never wobble";
    EXPECT_LT(std::abs(dy_max), 0.05) << kind;
  }
}

// Mixamo's skeleton without fingers, with an extra unmapped bone above the left thigh.
std::vector<test::RigBoneSpec> mixamo_specs() {
  return {{"Hips", 0, -1},          {"Spine", 3, 0},          {"Spine1", 6, 1},          {"Spine2", 9, 2},
          {"Neck", 12, 3},          {"Head", 15, 4},          {"LeftShoulder", 13, 3},   {"LeftArm", 16, 6},
          {"LeftForeArm", 18, 7},   {"LeftHand", 20, 8},      {"RightShoulder", 14, 3},  {"RightArm", 17, 10},
          {"RightForeArm", 19, 11}, {"RightHand", 21, 12},    {"LeftHipTwist", -1, 0},   {"LeftUpLeg", 1, 14},
          {"LeftLeg", 4, 15},       {"LeftFoot", 7, 16},      {"LeftToeBase", 10, 17},   {"RightUpLeg", 2, 0},
          {"RightLeg", 5, 19},      {"RightFoot", 8, 20},     {"RightToeBase", 11, 21}};
}

void expect_limbs_match(const Motion& m, const Motion& back, double tol_deg) {
  ASSERT_EQ(back.frames.size(), m.frames.size());
  for (int j = 0; j < 22; ++j) {
    double worst = 0;
    for (size_t t = 0; t < m.frames.size(); ++t) worst = std::max(worst, angle_deg(m.frames[t], back.frames[t], j));
    EXPECT_LT(worst, tol_deg) << kSmplxJointNames[j];
  }
  // Root travel in metres whatever the file's units (the leg-length ratio cancels them).
  const double travel = back.frames.back().transl[2] - back.frames.front().transl[2];
  EXPECT_NEAR(travel, m.frames.back().transl[2] - m.frames.front().transl[2], 2e-3);
}

TEST(MotionRetarget, MixamoBvhInAPoseWithAnExtraBone) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("walk", 36);
  const test::Rig rig = test::make_rig(m, rest, mixamo_specs(), 40, 0, 100);  // centimetres
  const std::string path = temp_file("mixamo.bvh").string();
  write_text_file(path, test::rig_bvh(rig));
  expect_limbs_match(m, retarget_file(path, "mixamo", 22), 1.0);
}

// The same skeleton with Mixamo's fingers (index, middle, pinky, ring, thumb; three bones each
// side), the arms, hands and fingers resting 40 degrees down: a thumb points partly forward, so
// only the arm's own turn, not the smallest turn of its own direction, brings it back.
TEST(MotionRetarget, APoseFingersTakeTheirArmsTurn) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  Motion m = demo("wave", 24);
  for (size_t t = 0; t < m.frames.size(); ++t)  // curl the fingers, each its own way
    for (int j = kLeftHandFirst; j < kNumJoints; ++j) m.frames[t].pose[size_t(3 * j)] = 0.02f * float((j % 7) * (t % 5));
  std::vector<test::RigBoneSpec> specs = mixamo_specs();
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const char* side : {"Left", "Right"})
      for (const char* finger : {"Index", "Middle", "Pinky", "Ring", "Thumb"})
        for (int k = 1; k <= 3; ++k) n.push_back(std::string(side) + "Hand" + finger + std::to_string(k));
    return n;
  }();
  for (size_t i = 0; i < names.size(); ++i) {
    const int hand = i < 15 ? 9 : 13;  // LeftHand, RightHand in mixamo_specs()
    const int parent = i % 3 == 0 ? hand : int(specs.size()) - 1;
    specs.push_back({names[i].c_str(), kLeftHandFirst + int(i), parent});
  }
  const test::Rig rig = test::make_rig(m, rest, specs, 40, 0, 100);
  const std::string path = temp_file("mixamo_fingers.bvh").string();
  write_text_file(path, test::rig_bvh(rig));
  const Motion back = retarget_file(path, "mixamo", 52);
  ASSERT_EQ(back.frames.size(), m.frames.size());
  for (int j = 0; j < kNumJoints; ++j) {
    if (j >= 22 && j < kLeftHandFirst) continue;  // jaw and eyes: not in the rig
    double worst = 0;
    for (size_t t = 0; t < m.frames.size(); ++t) worst = std::max(worst, angle_deg(m.frames[t], back.frames[t], j));
    EXPECT_LT(worst, 1.0) << kSmplxJointNames[j];
  }
}

TEST(MotionRetarget, ZUpRigFacingAnotherWayTurnsIntoHahasWorld) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("walk", 24);
  test::Rig rig = test::make_rig(m, rest, mixamo_specs(), 0, 0, 100);
  // Z up, facing -X (its left -Y): an axis permutation, so the turn back is exact.
  Mat3<double> W;
  W.a[1][0] = -1, W.a[2][1] = 1, W.a[0][2] = -1;
  test::turn_rig(rig, W);
  const std::string path = temp_file("zup.bvh").string();
  write_text_file(path, test::rig_bvh(rig));
  RetargetReport rep;
  const RigAnimation r = read_rig_animation(path);
  const Motion back = retarget_rig(r, choose_bone_map(builtin_bone_maps(), r.names), test::low_body(), RetargetOptions{false, {}}, &rep);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_EQ(rep.alignment.a[i][j], W.a[j][i]);  // A = W^T
  expect_limbs_match(m, back, 0.5);
}

// A rig built otherwise (an upright neck and head, a straight back) but posed the same: its
// torso's turns transfer as they are, not bent onto SMPL-X's own bone directions.
TEST(MotionRetarget, TorsoOfAnotherBuildKeepsItsTurns) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("kick", 24);
  test::Rig rig = test::make_rig(m, rest, mixamo_specs(), 0, 0, 100);
  for (size_t b = 1; b <= 5; ++b) {  // Spine .. Head straight above their parents
    const V3 below = rig.bones[size_t(rig.bones[b].parent)].rest_pos;
    rig.bones[b].rest_pos = below + V3(0, norm(rig.bones[b].rest_pos - below), 0);
  }
  const std::string path = temp_file("upright.bvh").string();
  write_text_file(path, test::rig_bvh(rig));
  expect_limbs_match(m, retarget_file(path, "mixamo", 22), 0.5);
}

// A rest whose torso bends forward (a file whose node transforms are a clip's first frame):
// the report measures the lean the torso then keeps in every frame.
TEST(MotionRetarget, ReportsARestTorsoThatDoesNotStand) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("walk", 8);
  const auto lean = [&](double bend_deg) {
    test::Rig rig = test::make_rig(m, rest, mixamo_specs(), 0, 0, 100);
    const double c = std::cos(bend_deg * M_PI / 180), s = std::sin(bend_deg * M_PI / 180);
    const V3 pelvis = rig.bones[0].rest_pos;
    for (size_t b = 1; b <= 13; ++b) {  // Spine .. the arms: the upper body turned about the pelvis's X axis
      const V3 d = rig.bones[b].rest_pos - pelvis;
      rig.bones[b].rest_pos = pelvis + V3(d.x, c * d.y - s * d.z, s * d.y + c * d.z);
    }
    const std::string path = temp_file("bent.bvh").string();
    write_text_file(path, test::rig_bvh(rig));
    const RigAnimation r = read_rig_animation(path);
    RetargetReport rep;
    retarget_rig(r, choose_bone_map(builtin_bone_maps(), r.names), test::low_body(), RetargetOptions{false, {}}, &rep);
    return rep.rest_torso_deg;
  };
  EXPECT_LT(lean(0), 0.5);
  EXPECT_NEAR(lean(40), 40, 3);
}

TEST(MotionRetarget, MixamoGlbWithRotatedBoneAxesInAPose) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("kick", 30);
  std::vector<test::RigBoneSpec> specs = mixamo_specs();
  std::vector<std::string> names;
  for (auto& s : specs) names.push_back("mixamorig:" + std::string(s.name));
  for (size_t i = 0; i < specs.size(); ++i) specs[i].name = names[i].c_str();
  const test::Rig rig = test::make_rig(m, rest, specs, 45, 7, 1);
  const std::string path = temp_file("mixamo.glb").string();
  test::write_rig_glb(rig, path);
  expect_limbs_match(m, retarget_file(path, "mixamo", 22), 1.0);
}

// The check counts the frames where the body's arm is inside its torso and the rig's is not:
// none for a faithful retarget; every frame once the body's left arm is swung down through
// its chest.
TEST(MotionRetarget, CheckCountsAnArmThroughTheTorsoTheRigDoesNotHave) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  const Motion m = demo("walk", 12);
  const test::Rig rig = test::make_rig(m, rest, mixamo_specs(), 0, 0, 100);
  const std::string path = temp_file("check.bvh").string();
  write_text_file(path, test::rig_bvh(rig));
  const RigAnimation r = read_rig_animation(path);
  const BoneMatch match = choose_bone_map(builtin_bone_maps(), r.names);
  RetargetReport rep;
  Motion back = retarget_rig(r, match, test::low_body(), RetargetOptions{false, {}}, &rep);
  const RetargetCheck ok = check_retarget(r, match, back, rest, rep, {});
  EXPECT_EQ(ok.frames, 12);
  EXPECT_EQ(ok.arm_in_torso_frames, 0);
  EXPECT_EQ(ok.rig_arm_in_torso_frames, 0);
  // The left shoulder turned 130 degrees about the forward axis: the arm points down and in,
  // the elbow and wrist through the chest.
  for (SmplxParams& p : back.frames) {
    p.pose[3 * 16 + 0] = p.pose[3 * 16 + 1] = 0.0f;
    p.pose[3 * 16 + 2] = float(-130 * M_PI / 180);
    p.pose[3 * 18 + 0] = p.pose[3 * 18 + 1] = p.pose[3 * 18 + 2] = 0.0f;
  }
  const RetargetCheck bad = check_retarget(r, match, back, rest, rep, {});
  EXPECT_EQ(bad.arm_in_torso_frames, 12);
  EXPECT_NE(retarget_check_line(bad).find("an arm inside the torso in 12 of 12 frames"), std::string::npos)
      << retarget_check_line(bad);
}

TEST(MotionRetarget, RotationBetweenTakesOneDirectionToTheOther) {
  const V3 pairs[][2] = {{V3(1, 0, 0), V3(0, 1, 0)}, {V3(0, 0, 1), V3(0, 0, -1)}, {V3(0.6, 0.8, 0), V3(0.6, 0.8, 0)}};
  for (const auto& [a, b] : pairs) {
    const Mat3<double> R = rotation_between(a, b);
    EXPECT_LT(norm(R * a - b), 1e-12);
    EXPECT_LT(norm(transpose(R) * R * V3(0.3, -0.2, 0.9) - V3(0.3, -0.2, 0.9)), 1e-12);  // orthonormal
  }
}

}  // namespace
}  // namespace haha
