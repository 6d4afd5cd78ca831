// A rig's animation (app/rig_import.h) as an SMPL-X motion, through a bone map
// (app/bone_map.h). Rotations transfer in world space relative to each skeleton's own rest:
//   G_j(t) = A R_n(t) R_n(rest)^T A^T C_j
// for SMPL-X joint j bound to node n, where
//   - A is the rotation taking the rig's world to haha's (Y up, facing +Z, left = +X): the
//     rig's rest left (left hip - right hip) and up (pelvis -> head) snapped to the nearest
//     axes, so an axis-aligned file turns exactly;
//   - C_j is the rest offset of a limb's bone (thigh, shin, upper arm, forearm, hand,
//     finger): the smallest rotation taking the SMPL-X rest bone direction
//     (j -> kSmplxBoneChild[j]) to the rig's, so an A-pose rest and a T-pose rest land with
//     the same limb directions; a limb joint without a bound child, an ankle or a foot takes
//     its parent's (a hand hangs along its forearm). The torso, collars, neck and head keep
//     C = I: their rest directions differ between skeletons by build, not by pose;
// and a joint the rig lacks keeps its parent's world rotation (rests locally): a rig's bone
// that no joint takes folds into its bound ancestor by working in world space. Local
// axis-angle follows from the parent chain, L_j = G_parent^T G_j.
// The pelvis path is scaled by the ratio of the leg lengths (SMPL-X / rig, whatever the
// rig's units), its lowest ankle put at the body's rest ankle height, and the feet held
// where the rig's feet stand (app/foot_lock.h).
#pragma once

#include <string>
#include <vector>

#include "app/bone_map.h"
#include "app/foot_lock.h"
#include "app/rig_import.h"
#include "body/body_model.h"
#include "io/motion.h"

namespace haha {

struct RetargetOptions {
  bool lock_feet = true;
  FootLockParams contacts;
};

struct RetargetReport {
  std::vector<int> at_rest;  // SMPL-X body joints (0..21) the rig lacks
  double scale = 1;          // body's leg length / rig's (rig units -> metres)
  int contacts = 0;          // foot contacts held
  Mat3<double> alignment = Mat3<double>::identity();  // A: the rig's world to haha's
  // Degrees between the torso (pelvis to neck) of the rig's rest, turned by A, and SMPL-X's
  // rest torso. The torso, neck and head transfer the rig's turn from its rest, so a rest
  // that is not standing (a file whose node transforms are a clip's first frame, not its
  // bind pose) leans them by this much in every frame. NaN: no neck or head bound.
  double rest_torso_deg = 0;
};

// Throws haha::Error "rig.source: problem" when the map binds no pelvis, or no left-right
// pair (hips, shoulders) and no joint above the pelvis to tell the rig's axes.
Motion retarget_rig(const RigAnimation& rig, const BoneMatch& match, const BodyModel& body, const RetargetOptions& options,
                    RetargetReport* report = nullptr);

// The smallest rotation taking unit vector a to unit vector b.
Mat3<double> rotation_between(const Vec3<double>& a, const Vec3<double>& b);

}  // namespace haha
