// `haha synth`'s driver: the embedded sample. A clothed synthetic subject rendered as a
// monocular video with masks, a static camera and per-frame SMPL-X fits, in the native
// dataset format (data/synth_dataset.h, synth/synth_subject.h); optionally also as X-Humans
// takes for `haha convert --from xhumans`. With a motion file, the same subject in the
// motion's poses, every frame a test frame (ground truth for an avatar reposed by it).
#pragma once

#include <optional>
#include <string>

#include "data/synth_dataset.h"

namespace haha {

struct SynthRunOptions {
  std::string out;
  std::string body;                // body model .npz; empty: the procedural body (saved in OUT)
  std::string resolution = "full";  // of the procedural body: low or full
  std::string xhumans;             // non-empty: also write X-Humans takes under this folder
  SynthOptions synth;              // fit_noise is set from the three values below
  double fit_noise = 0;            // sigma of both, unless one is given on its own
  std::optional<double> fit_noise_pose, fit_noise_transl;  // not given: fit_noise
  bool part_masks = false;         // also write DIR/part_masks/ (data/synth_dataset.h)
  // --motion: the subject in a motion file's poses instead of the turn and the novel poses
  // (io/motion.h reads it; thinned as `haha render` thins: resampled to `rate` first, then
  // every `every`-th frame, at most `max_frames`).
  std::string motion;
  int every = 1, max_frames = 0;
  double rate = 0;
};

// Writes the dataset, printing one line per part and a summary. Throws haha::Error naming
// the option or file for bad input, before any work.
void run_synth(const SynthRunOptions& options);

}  // namespace haha
