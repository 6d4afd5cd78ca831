// The bone maps and their chooser (app/bone_map.h): each rig's names pick their own map,
// joints land where that rig's convention puts them, and a user's map is checked.
#include "app/bone_map.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "body/joint_names.h"
#include "core/atomic_file.h"
#include "support/expect_error.h"

namespace haha {
namespace {

std::string joint_of(const BoneMatch& m, const std::vector<std::string>& names, const std::string& bone) {
  for (int j = 0; j < kNumJoints; ++j)
    if (m.node_of[size_t(j)] >= 0 && names[size_t(m.node_of[size_t(j)])] == bone) return kSmplxJointNames[j];
  return "";
}

TEST(BoneMap, NamesNormalise) {
  EXPECT_EQ(normalise_bone_name("mixamorig:LeftUpLeg"), "leftupleg");
  EXPECT_EQ(normalise_bone_name("Armature:mixamorig1:Hips"), "hips");
  EXPECT_EQ(normalise_bone_name("thigh.L"), "thighl");
  EXPECT_EQ(normalise_bone_name("Left_Up-Leg"), "leftupleg");
}

TEST(BoneMap, EachRigPicksItsMap) {
  const std::vector<std::string> mixamo = {"mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2",
                                           "mixamorig:Neck", "mixamorig:Head", "mixamorig:LeftArm", "mixamorig:RightArm",
                                           "mixamorig:LeftUpLeg", "mixamorig:RightUpLeg", "mixamorig:LeftHandIndex1"};
  const std::vector<std::string> cmu = {"Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "RHipJoint", "RightUpLeg",
                                        "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "LeftShoulder", "LeftArm"};
  const std::vector<std::string> vrm = {"hips", "spine", "chest", "upperChest", "neck", "head", "leftUpperLeg",
                                        "rightUpperLeg", "leftLowerArm", "rightHand"};
  const std::vector<std::string> rigify = {"Armature", "spine", "spine.001", "spine.002", "spine.003", "spine.004",
                                           "spine.006", "thigh.L", "shin.R", "DEF-upper_arm.L", "hand.R"};
  const std::vector<std::string> smplx = {"pelvis", "left_hip", "right_hip", "spine1", "left_knee", "spine2", "neck", "head"};
  const auto& maps = builtin_bone_maps();
  const BoneMatch a = choose_bone_map(maps, mixamo), b = choose_bone_map(maps, cmu), c = choose_bone_map(maps, vrm),
                  d = choose_bone_map(maps, rigify), e = choose_bone_map(maps, smplx);
  EXPECT_EQ(a.map, "mixamo");
  EXPECT_EQ(a.matched, 11);
  EXPECT_EQ(joint_of(a, mixamo, "mixamorig:Spine2"), "spine3");
  EXPECT_EQ(joint_of(a, mixamo, "mixamorig:LeftArm"), "left_shoulder");
  EXPECT_EQ(joint_of(a, mixamo, "mixamorig:LeftHandIndex1"), "left_index1");
  EXPECT_EQ(b.map, "cmu");
  EXPECT_EQ(joint_of(b, cmu, "LowerBack"), "spine1");
  EXPECT_EQ(joint_of(b, cmu, "Spine1"), "spine3");
  EXPECT_EQ(joint_of(b, cmu, "LHipJoint"), "");  // folded into the hips
  EXPECT_EQ(c.map, "vrm");
  EXPECT_EQ(joint_of(c, vrm, "upperChest"), "spine3");
  EXPECT_EQ(joint_of(c, vrm, "leftLowerArm"), "left_elbow");
  EXPECT_EQ(d.map, "rigify");
  EXPECT_EQ(joint_of(d, rigify, "spine"), "pelvis");
  EXPECT_EQ(joint_of(d, rigify, "shin.R"), "right_knee");
  EXPECT_EQ(joint_of(d, rigify, "DEF-upper_arm.L"), "left_shoulder");
  EXPECT_EQ(e.map, "smplx");
  EXPECT_EQ(e.matched, 8);
}

TEST(BoneMap, FirstNodeWinsAJoint) {
  const BoneMatch m = match_bone_map(builtin_bone_maps()[0], {"root", "pelvis", "Pelvis"});
  EXPECT_EQ(m.node_of[0], 1);
  EXPECT_EQ(m.matched, 1);
}

TEST(BoneMap, UserMapFromJson) {
  const auto dir = std::filesystem::temp_directory_path() / ("haha-bone-map-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string good = (dir / "good.json").string(), bad = (dir / "bad.json").string(), odd = (dir / "odd.json").string();
  write_text_file(good, R"({"Bip01 Pelvis": "pelvis", "Bip01 L Thigh": "left_hip", "Bip01 Head": "head"})");
  write_text_file(bad, R"({"Bip01 Pelvis": "pelvis", "Bip01 L Thigh": "left_thigh"})");
  write_text_file(odd, R"(["pelvis"])");
  const BoneMap m = read_bone_map(good);
  const BoneMatch r = choose_bone_map({m}, {"Bip01", "Bip01 Pelvis", "Bip01 L Thigh", "Bip01 Spine", "Bip01 Head"});
  EXPECT_EQ(r.map, good);
  EXPECT_EQ(r.matched, 3);
  EXPECT_EQ(r.node_of[1], 2);
  test::expect_error_at(bad + ": Bip01 L Thigh", [&] { read_bone_map(bad); }, {"'left_thigh' is not an SMPL-X joint name"});
  test::expect_error_at(odd, [&] { read_bone_map(odd); }, {"expected a JSON object"});
  test::expect_error_at((dir / "none.json").string(), [&] { read_bone_map((dir / "none.json").string()); }, {});
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace haha
