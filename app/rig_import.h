// A skeleton animation from a mocap or rig file (BVH, FBX, glTF / GLB, Collada, and what
// else Assimp reads), sampled at the file's own frame rate: every node's local transform at
// rest and per frame, for the retargeter (app/motion_retarget.h). Assimp does the parsing;
// the scene's own units and axis conversions stay in the nodes' transforms, so world
// transforms come out in the file's world.
#pragma once

#include <string>
#include <vector>

#include "core/math.h"

namespace haha {

// x -> m x + t (m may scale: FBX files often carry a unit scale on a node).
struct Affine {
  Mat3<double> m = Mat3<double>::identity();
  Vec3<double> t{};
};
Affine operator*(const Affine& a, const Affine& b);

struct RigAnimation {
  std::string source;                     // the file
  std::string take;                       // the animation read
  std::vector<std::string> takes;         // every animation in the file, in file order
  std::vector<std::string> names;         // the scene's nodes, parents before children
  std::vector<int> parents;               // (nodes), -1 for the scene's root
  std::vector<Affine> rest;               // (nodes) local transform without the animation
  double fps = 30;                        // frames per second of `frames`
  std::vector<std::vector<Affine>> frames;  // (T, nodes) local transforms
};

// Reads `take` ("" = the first animation). Throws haha::Error "path: problem" for a file
// Assimp cannot read, a scene without a skeleton (fewer than two nodes) or without an
// animation, an unknown take (naming the takes there are) or a clip too large to hold.
RigAnimation read_rig_animation(const std::string& path, const std::string& take = "");

// World transforms of every node: (nodes) from `local` (the rest, or one frame).
std::vector<Affine> world_transforms(const RigAnimation& rig, const std::vector<Affine>& local);

}  // namespace haha
