// The glTF animations of a .glb avatar, read back as joint tracks (format/animation.h).
// Checked like every other section (format/spec.md section 5): a bad index, type, count,
// key time or value gives one haha::Error "<file>: animations[i]...: <problem>", and no
// input makes the reader allocate more values than the file's BIN chunk holds bytes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/animation.h"
#include "format/glb.h"

namespace haha {

// Joint j is the node skins[0].joints[j] (j < 55). Channels on other nodes, and morph
// `weights` channels, do not move the skeleton and are skipped; a scale channel on a joint,
// a translation on a joint other than the root, CUBICSPLINE interpolation and two channels
// on one (joint, path) are rejected.
std::vector<AvatarAnimation> read_animations(const glb::Glb& g, const std::string& where);

// Parses the container and reads only the animations (the fuzz target's entry).
std::vector<AvatarAnimation> read_glb_animations(const uint8_t* data, size_t size, const std::string& where);

}  // namespace haha
