// SMPL-X joint names in joint order (the names SMPL-X's own tools print; the eyes are
// "left_eye_smplhf" there, plain "left_eye" here), and the joint whose direction from a
// joint is that joint's bone (its limb), for code that matches skeletons by name or by
// bone direction.
#pragma once

#include "body/body_model.h"

namespace haha {

inline constexpr const char* kSmplxJointNames[kNumJoints] = {
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
    "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "jaw",
    "left_eye", "right_eye", "left_index1", "left_index2", "left_index3", "left_middle1", "left_middle2",
    "left_middle3", "left_pinky1", "left_pinky2", "left_pinky3", "left_ring1", "left_ring2", "left_ring3",
    "left_thumb1", "left_thumb2", "left_thumb3", "right_index1", "right_index2", "right_index3",
    "right_middle1", "right_middle2", "right_middle3", "right_pinky1", "right_pinky2", "right_pinky3",
    "right_ring1", "right_ring2", "right_ring3", "right_thumb1", "right_thumb2", "right_thumb3"};

// The joint a joint's bone points to (-1: none, e.g. the pelvis, which has three, and the
// ends). The spine's top points to the neck, a wrist to its middle finger.
inline constexpr int kSmplxBoneChild[kNumJoints] = {
    -1, 4, 5, 6, 7, 8, 9, 10, 11, 12, -1, -1, 15, 16, 17, -1, 18, 19, 20, 21, 28, 43, -1, -1, -1,
    26, 27, -1, 29, 30, -1, 32, 33, -1, 35, 36, -1, 38, 39, -1,
    41, 42, -1, 44, 45, -1, 47, 48, -1, 50, 51, -1, 53, 54, -1};

// Index of a joint name (kSmplxJointNames, or "left_eye_smplhf" / "right_eye_smplhf"); -1
// when unknown.
int smplx_joint_index(const char* name);

}  // namespace haha
