// Motions -> glTF animations of the avatar's joint nodes (format/spec.md section 2,
// "Animations"), so any glTF viewer plays them on the skinned body: a rotation channel per
// joint, the root's translation, LINEAR at the motion's frame rate. Internal to haha_format:
// avatar_pack.cpp calls it (PackOptions::animations).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "format/glb.h"
#include "io/motion.h"

namespace haha {

// Keyframe reduction: a key is dropped when the reader's LINEAR interpolation (slerp) of
// the kept keys around it reproduces it within this many radians (translations: this many
// metres, what the angle moves a point 1 m from the joint by). 1e-3 rad (0.057 deg) moves a
// hand 0.9 m from the pelvis by under 1 mm per joint: below a pixel of a full-body view,
// and far below a video fit's own jitter. 0 keeps every key.
inline constexpr double kDefaultAnimationTolerance = 1e-3;

struct AnimationSource {
  std::string name;  // the glTF animation's name (unique within a file)
  Motion motion;     // any up axis (turned to Y-up about the avatar's rest pelvis)
  double tolerance = kDefaultAnimationTolerance;  // radians (see above); 0: every key
};

// Bits of a stored rotation component: 16 (normalized short, the default), 8 (normalized
// byte) or 0 (float32). glTF 2.0 allows all three for rotation outputs without extensions.
inline constexpr int kDefaultAnimationRotationBits = 16;

// The largest error of one stored rotation component: half a step of the normalized code
// (0 for float32). A key's rotation angle then differs from the motion's by at most about
// 4x this (2 |dq| over four components).
double animation_component_error(int rotation_bits);

// Appends one animation per source to `bin` (one bufferView each) and `accessors`; returns
// the glTF "animations" array. Joint j is node j (the packer's skeleton, spec section 2);
// rest_joints (55, 3) are the skeleton's rest joints (the root node's translation is J0).
// bytes_each (optional) receives the bufferView size of each animation. Throws haha::Error
// naming the motion's file for an empty motion, a duplicate name, non-finite values or a
// negative tolerance.
glb::Json pack_animations(glb::BinWriter& bin, glb::Json& accessors, const std::vector<AnimationSource>& sources,
                          const std::vector<double>& rest_joints, int rotation_bits, std::vector<size_t>* bytes_each = nullptr);

}  // namespace haha
