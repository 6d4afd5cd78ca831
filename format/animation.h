// glTF animations of an avatar's skeleton, as haha reads them back (format/spec.md section
// 2, "Animations"): per joint a rotation track, for the root also a translation track, each
// LINEAR (slerp / lerp between keys) or STEP, held at the first / last key outside them.
// Sampling turns a time into SMPL-X pose parameters, so every reader of motions (haha
// render, the runtime, Python) plays a file's animation through the motion path it has.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "io/motion.h"

namespace haha {

struct AnimationTrack {
  int joint = 0;               // SMPL-X joint 0..54
  bool translation = false;    // false: rotation (values (K, 4) unit quaternions w, x, y, z)
  bool step = false;           // STEP interpolation (else LINEAR)
  std::vector<float> times;    // (K) seconds, strictly increasing
  std::vector<float> values;   // (K, 4) rotations or (K, 3) root translations (transl, i.e.
                               // the node's translation minus its rest translation)
};

struct AvatarAnimation {
  std::string name;
  double duration = 0;   // seconds: the last key of any track
  int frames = 0;        // frames sampled at the packer's rate (extras.fps), else keys of its longest track
  size_t bytes = 0;      // bytes of its bufferViews in the file
  std::vector<AnimationTrack> tracks;  // at most one per (joint, kind); untracked joints rest
};

// Pose parameters at time t (seconds; clamped to [0, duration]): pose from the rotation
// tracks (axis-angle), transl from the root's translation track, zero elsewhere.
SmplxParams sample_animation(const AvatarAnimation& a, double t);

// The frame rate the animation was written at: (frames - 1) / duration, 30 for one frame.
double animation_rate(const AvatarAnimation& a);

// The animation sampled at `fps` (0: its own rate) into a Y-up motion, frame k at k / fps.
Motion animation_motion(const AvatarAnimation& a, double fps = 0);

// Index of the animation named `key`, or `key` read as an index; throws haha::Error naming
// `where` and listing the names when there is none.
size_t find_animation(const std::vector<AvatarAnimation>& list, const std::string& key, const std::string& where);

}  // namespace haha
