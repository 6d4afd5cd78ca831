// `haha pack`'s driver: a trained run directory (RUN/avatar.npz + config.json "model", see
// app/run_dir.h), or an avatar.npz with its body model, to one .glb (format/spec.md).
// `haha pack` parses its options into PackOptions and calls it; so does `haha batch run`.
#pragma once

#include <string>
#include <vector>

#include "format/avatar_pack.h"

namespace haha {

// Motion files to store as glTF animations (`haha pack --animation`).
struct PackAnimations {
  std::vector<std::string> files;  // motion .npz files (io/motion.h), one animation each
  std::vector<std::string> names;  // names of the first files (default: the file's stem)
  double rate = 0;                 // resample every motion to this rate (0: keep its own)
  double tolerance = kDefaultAnimationTolerance;  // keyframe reduction, radians (0: every key)
};

// `model` empty: config.json's "model" (a run directory); an avatar.npz given directly needs
// it. Writes `out` atomically. Throws haha::Error naming the file or option.
PackedSizes pack_run(const std::string& run_or_npz, const std::string& model, const std::string& out,
                     const PackOptions& options, const PackAnimations& animations = {});

}  // namespace haha
