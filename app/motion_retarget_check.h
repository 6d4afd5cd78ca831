// How faithful a retargeted motion is to its rig, measured on the two skeletons' own joints:
// the angle between each limb's direction in the rig and in the body (upper arm, forearm,
// thigh, shin, spine = pelvis -> spine3, neck = neck -> head; both sides, mean over frames),
// and how far the body's ankles slide while the rig's ankles stand (a contact as
// app/foot_lock.h detects it, on the rig's ankles scaled to metres): the largest horizontal
// distance from where the ankle was when the contact began, mean over contacts; and the
// frames where an elbow or wrist of the body is inside its torso (within kTorsoRadius of the
// pelvis-spine-neck line) while the rig's, scaled, is not: an arm through the body that the
// source does not have.
#pragma once

#include <array>
#include <string>

#include "app/bone_map.h"
#include "app/foot_lock.h"
#include "app/motion_retarget.h"
#include "app/rig_import.h"
#include "body/rest_skeleton.h"
#include "io/motion.h"

namespace haha {

struct RetargetCheck {
  static constexpr int kLimbs = 6;
  static constexpr const char* kLimbNames[kLimbs] = {"upper arm", "forearm", "thigh", "shin", "spine", "neck"};
  std::array<double, kLimbs> limb_deg{};  // mean angle; NaN where the rig lacks the limb
  int contacts = 0;                       // the rig's ankle contacts
  double slide_cm = 0;                    // the body's ankles during them (mean over contacts)
  double rig_slide_cm = 0;                // the rig's own ankles, scaled to the body
  int frames = 0;                         // frames compared
  int arm_in_torso_frames = 0;            // body's elbow / wrist inside the torso, the rig's not
  int rig_arm_in_torso_frames = 0;        // the rig's own (scaled), for comparison
  static constexpr double kTorsoRadius = 0.08;  // metres: deep inside any adult torso
};

// `m`, `report`: retarget_rig's result for `rig` through `match` (same frames).
RetargetCheck check_retarget(const RigAnimation& rig, const BoneMatch& match, const Motion& m, const RestSkeleton& body,
                             const RetargetReport& report, const FootLockParams& contacts);

// One line: "limb directions against the rig: upper arm 0.21 deg, ...; ankles slide ...".
std::string retarget_check_line(const RetargetCheck& c);

}  // namespace haha
