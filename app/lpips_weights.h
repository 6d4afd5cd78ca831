// Reads the user-supplied LPIPS weight file (.npz, layout and export recipe in
// train/lpips.h) into the plain struct the train layer builds its network from. Kept in
// the application layer: haha_train itself reads no files.
#pragma once

#include <string>

#include "train/lpips.h"

namespace haha {

// Every array whose key starts with "alex." or "vgg." (other keys are ignored), as
// float32; LpipsWeights::source = path. Throws haha::Error naming the file (and key) for
// an unreadable file, a non-float array, or a file with no LPIPS arrays at all. Key and
// shape checks against the architecture happen in LpipsNet's constructor, which names
// the same file.
LpipsWeights read_lpips_weights(const std::string& path);

}  // namespace haha
