#include "app/bone_map.h"

#include <cctype>

#include "body/joint_names.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "io/json_text.h"

namespace haha {

namespace {

struct Pair {
  const char* source;
  const char* joint;
};

// Left side only: left_side_too() adds the mirror (Left/Right, L/R, left/right, .L/.R).
constexpr Pair kMixamo[] = {
    {"Hips", "pelvis"}, {"Spine", "spine1"}, {"Spine1", "spine2"}, {"Spine2", "spine3"}, {"Neck", "neck"},
    {"Head", "head"}, {"LeftUpLeg", "left_hip"}, {"LeftLeg", "left_knee"}, {"LeftFoot", "left_ankle"},
    {"LeftToeBase", "left_foot"}, {"LeftToe", "left_foot"}, {"LeftShoulder", "left_collar"}, {"LeftArm", "left_shoulder"},
    {"LeftForeArm", "left_elbow"}, {"LeftHand", "left_wrist"}, {"LeftHandIndex1", "left_index1"},
    {"LeftHandIndex2", "left_index2"}, {"LeftHandIndex3", "left_index3"}, {"LeftHandMiddle1", "left_middle1"},
    {"LeftHandMiddle2", "left_middle2"}, {"LeftHandMiddle3", "left_middle3"}, {"LeftHandPinky1", "left_pinky1"},
    {"LeftHandPinky2", "left_pinky2"}, {"LeftHandPinky3", "left_pinky3"}, {"LeftHandRing1", "left_ring1"},
    {"LeftHandRing2", "left_ring2"}, {"LeftHandRing3", "left_ring3"}, {"LeftHandThumb1", "left_thumb1"},
    {"LeftHandThumb2", "left_thumb2"}, {"LeftHandThumb3", "left_thumb3"}};
// CMU's BVH (the cgspeed conversion): LowerBack / Spine / Spine1 up the back; LHipJoint and
// Neck1 have no SMPL-X joint and fold into their parents.
constexpr Pair kCmu[] = {
    {"Hips", "pelvis"}, {"LowerBack", "spine1"}, {"Spine", "spine2"}, {"Spine1", "spine3"}, {"Neck", "neck"},
    {"Head", "head"}, {"LeftUpLeg", "left_hip"}, {"LeftLeg", "left_knee"}, {"LeftFoot", "left_ankle"},
    {"LeftToeBase", "left_foot"}, {"LeftShoulder", "left_collar"}, {"LeftArm", "left_shoulder"},
    {"LeftForeArm", "left_elbow"}, {"LeftHand", "left_wrist"}};
constexpr Pair kVrm[] = {
    {"hips", "pelvis"}, {"spine", "spine1"}, {"chest", "spine2"}, {"upperChest", "spine3"}, {"neck", "neck"},
    {"head", "head"}, {"jaw", "jaw"}, {"leftEye", "left_eye"}, {"leftUpperLeg", "left_hip"},
    {"leftLowerLeg", "left_knee"}, {"leftFoot", "left_ankle"}, {"leftToes", "left_foot"},
    {"leftShoulder", "left_collar"}, {"leftUpperArm", "left_shoulder"}, {"leftLowerArm", "left_elbow"},
    {"leftHand", "left_wrist"}, {"leftIndexProximal", "left_index1"}, {"leftIndexIntermediate", "left_index2"},
    {"leftIndexDistal", "left_index3"}, {"leftMiddleProximal", "left_middle1"},
    {"leftMiddleIntermediate", "left_middle2"}, {"leftMiddleDistal", "left_middle3"},
    {"leftLittleProximal", "left_pinky1"}, {"leftLittleIntermediate", "left_pinky2"},
    {"leftLittleDistal", "left_pinky3"}, {"leftRingProximal", "left_ring1"}, {"leftRingIntermediate", "left_ring2"},
    {"leftRingDistal", "left_ring3"}, {"leftThumbMetacarpal", "left_thumb1"}, {"leftThumbProximal", "left_thumb2"},
    {"leftThumbIntermediate", "left_thumb2"}, {"leftThumbDistal", "left_thumb3"}};
// Blender's metarig / Rigify deform bones (a bone's node sits at its head: "spine" starts at
// the pelvis; spine.004-.005 are the neck, spine.006 the head).
constexpr Pair kRigify[] = {
    {"spine", "pelvis"}, {"spine.001", "spine1"}, {"spine.002", "spine2"}, {"spine.003", "spine3"},
    {"spine.004", "neck"}, {"spine.006", "head"}, {"thigh.L", "left_hip"}, {"shin.L", "left_knee"},
    {"foot.L", "left_ankle"}, {"toe.L", "left_foot"}, {"shoulder.L", "left_collar"},
    {"upper_arm.L", "left_shoulder"}, {"forearm.L", "left_elbow"}, {"hand.L", "left_wrist"},
    {"f_index.01.L", "left_index1"}, {"f_index.02.L", "left_index2"}, {"f_index.03.L", "left_index3"},
    {"f_middle.01.L", "left_middle1"}, {"f_middle.02.L", "left_middle2"}, {"f_middle.03.L", "left_middle3"},
    {"f_pinky.01.L", "left_pinky1"}, {"f_pinky.02.L", "left_pinky2"}, {"f_pinky.03.L", "left_pinky3"},
    {"f_ring.01.L", "left_ring1"}, {"f_ring.02.L", "left_ring2"}, {"f_ring.03.L", "left_ring3"},
    {"thumb.01.L", "left_thumb1"}, {"thumb.02.L", "left_thumb2"}, {"thumb.03.L", "left_thumb3"}};

// The right side's name of a left-side name ("" when it has no side).
std::string mirrored(const std::string& s) {
  for (const char* a : {"Left", "left"}) {
    const size_t i = s.find(a);
    if (i != std::string::npos) return s.substr(0, i) + (a[0] == 'L' ? "Right" : "right") + s.substr(i + 4);
  }
  if (s.size() > 2 && s.compare(s.size() - 2, 2, ".L") == 0) return s.substr(0, s.size() - 2) + ".R";
  return "";
}

BoneMap make(const char* name, const Pair* pairs, size_t n, const char* extra_prefix = nullptr) {
  BoneMap m{name, {}};
  const auto add = [&](const std::string& src, const std::string& joint) {
    m.entries.emplace_back(normalise_bone_name(src), smplx_joint_index(joint.c_str()));
    if (extra_prefix) m.entries.emplace_back(normalise_bone_name(extra_prefix + src), smplx_joint_index(joint.c_str()));
  };
  for (size_t i = 0; i < n; ++i) {
    add(pairs[i].source, pairs[i].joint);
    const std::string r = mirrored(pairs[i].source);
    if (!r.empty()) add(r, mirrored(pairs[i].joint));
  }
  return m;
}

BoneMap smplx_map() {
  BoneMap m{"smplx", {}};
  for (int j = 0; j < kNumJoints; ++j) m.entries.emplace_back(normalise_bone_name(kSmplxJointNames[j]), j);
  m.entries.emplace_back(normalise_bone_name("left_eye_smplhf"), int(kLeftEye));
  m.entries.emplace_back(normalise_bone_name("right_eye_smplhf"), int(kRightEye));
  return m;
}

}  // namespace

std::string normalise_bone_name(const std::string& name) {
  const size_t colon = name.rfind(':');
  std::string out;
  for (size_t i = colon == std::string::npos ? 0 : colon + 1; i < name.size(); ++i) {
    const char c = name[i];
    if (c == ' ' || c == '_' || c == '.' || c == '-') continue;
    out += char(std::tolower(static_cast<unsigned char>(c)));
  }
  return out;
}

const std::vector<BoneMap>& builtin_bone_maps() {
  static const std::vector<BoneMap> maps = {
      smplx_map(),
      make("mixamo", kMixamo, std::size(kMixamo)),
      make("cmu", kCmu, std::size(kCmu)),
      make("vrm", kVrm, std::size(kVrm)),
      make("rigify", kRigify, std::size(kRigify), "DEF-"),
  };
  return maps;
}

BoneMap read_bone_map(const std::string& path) {
  const nlohmann::json j = parse_json_text(read_text_file(path), path);
  if (!j.is_object() || j.empty()) fail(path, "expected a JSON object {\"source bone\": \"smplx_joint_name\", ...}");
  BoneMap m{path, {}};
  for (const auto& [key, value] : j.items()) {
    if (!value.is_string()) fail(path + ": " + key, "expected an SMPL-X joint name (a string)");
    const std::string joint = value.get<std::string>();
    const int index = smplx_joint_index(joint.c_str());
    if (index < 0) fail(path + ": " + key, "'" + joint + "' is not an SMPL-X joint name (pelvis, left_hip, ..., right_thumb3)");
    m.entries.emplace_back(normalise_bone_name(key), index);
  }
  return m;
}

BoneMatch match_bone_map(const BoneMap& map, const std::vector<std::string>& node_names) {
  BoneMatch r{map.name, std::vector<int>(kNumJoints, -1), 0};
  for (size_t n = 0; n < node_names.size(); ++n) {
    const std::string key = normalise_bone_name(node_names[n]);
    for (const auto& [source, joint] : map.entries)
      if (source == key && r.node_of[size_t(joint)] < 0) r.node_of[size_t(joint)] = int(n), ++r.matched;
  }
  return r;
}

BoneMatch choose_bone_map(const std::vector<BoneMap>& maps, const std::vector<std::string>& node_names) {
  BoneMatch best;
  for (const BoneMap& m : maps) {
    BoneMatch r = match_bone_map(m, node_names);
    if (best.map.empty() || r.matched > best.matched) best = std::move(r);
  }
  return best;
}

}  // namespace haha
