// Which node of a rig is which SMPL-X joint: built-in maps for the common rigs (Mixamo,
// CMU-style BVH, VRM humanoid, Blender Rigify / metarig, SMPL-X's own names), a user's
// JSON map, and the chooser that picks the built-in map matching most of a file's nodes.
// Names compare normalised (normalise_bone_name): case, a namespace prefix ("mixamorig:")
// and the separators ' ', '_', '.', '-' do not matter.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace haha {

struct BoneMap {
  std::string name;                                  // "mixamo", "cmu", ..., or the JSON file
  std::vector<std::pair<std::string, int>> entries;  // normalised source name -> SMPL-X joint
};

// The built-in maps, in the order a tie is resolved.
const std::vector<BoneMap>& builtin_bone_maps();

// "mixamorig:LeftUpLeg" -> "leftupleg", "thigh.L" -> "thighl".
std::string normalise_bone_name(const std::string& name);

// A JSON object {"source bone": "smplx_joint_name", ...}. Throws haha::Error "path: problem"
// (or "path: <key>: problem") for unreadable JSON, an empty map or a value that is not an
// SMPL-X joint name. Two names may map to one joint (alternatives: the first node wins).
BoneMap read_bone_map(const std::string& path);

struct BoneMatch {
  std::string map;            // the map's name
  std::vector<int> node_of;   // (55) node index of each SMPL-X joint, -1 where the rig lacks it
  int matched = 0;            // joints with a node
};

// The nodes matched through one map: a joint takes the first node (parents before children)
// whose name maps to it.
BoneMatch match_bone_map(const BoneMap& map, const std::vector<std::string>& node_names);

// The map (of `maps`) with the most matched joints; the earlier one on a tie.
BoneMatch choose_bone_map(const std::vector<BoneMap>& maps, const std::vector<std::string>& node_names);

}  // namespace haha
