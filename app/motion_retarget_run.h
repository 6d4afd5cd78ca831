// `haha motion --retarget FILE`: a skeleton animation from BVH, FBX, glTF / GLB or Collada
// (app/rig_import.h) through a bone map (app/bone_map.h: the built-in map matching most
// bones, or --map) onto the SMPL-X body (app/motion_retarget.h), written as the motion .npz
// every command takes; and `haha motion --in M.npz --out M.bvh`, a motion as a BVH of the
// body's skeleton (io/motion_bvh.h).
#pragma once

#include <string>

#include "app/motion_retarget.h"
#include "body/body_model.h"

namespace haha {

struct MotionRetargetOptions {
  std::string in, out;  // rig file, motion .npz
  std::string take;     // animation name ("" = the first)
  std::string map;      // JSON bone map ("" = the best built-in map)
  double fps = 0;       // resample to this rate (0 = the file's own)
  RetargetOptions retarget;
};

// Prints what was read, the map line (which map, how many joints matched, which body joints
// rest) and what was written. Throws haha::Error naming the file for bad input.
void run_motion_retarget(const MotionRetargetOptions& o, const BodyModel& body);

// Reads a motion (io/motion.h), turns it Y-up for `body` and writes it as BVH to `out`.
void run_motion_to_bvh(const std::string& in, const std::string& out, const BodyModel& body);

}  // namespace haha
