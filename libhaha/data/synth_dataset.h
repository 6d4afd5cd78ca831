// `haha synth`: the synthetic subject's frames (synth/synth_subject.h) written in the native
// dataset format (data/dataset.h), with a contact sheet and the body atlas.
#pragma once

#include <cstdint>
#include <string>

#include "body/procedural_body.h"
#include "synth/synth_subject.h"

namespace haha {

// The body `haha synth` uses: `path` loaded when given, else the procedural body.
BodyModel synth_body(const std::string& path, BodyResolution resolution, uint64_t seed);

struct SynthSummary {
  Camera camera;
  int train_frames = 0, test_frames = 0;
  int texture_size = 0;
  double min_pose_gap = 0;  // measured min over (test, train) pairs of pose_distance
};

// Renders the whole dataset into `dir` through DatasetWriter, plus dir/contact_sheet.png,
// dir/synth_texture.png (the body atlas: what an ideal learned texture holds) and, when
// `save_body` is set, dir/body_model.npz (the body used). All of it is assembled beside
// `dir` and moved into place at the end: a failure leaves `dir` untouched. An existing
// `dir` is replaced only if it is empty or holds a dataset.json. `log` (may be null)
// receives progress lines.
SynthSummary write_synth_dataset(const std::string& dir, const BodyModel& body, const SynthOptions& opt,
                                 bool save_body, void (*log)(const std::string&) = nullptr);

}  // namespace haha
