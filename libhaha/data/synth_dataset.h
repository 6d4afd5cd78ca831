// `haha synth`: the synthetic subject's frames (synth/synth_subject.h) written in the native
// dataset format (data/dataset.h), with a contact sheet and the body atlas.
#pragma once

#include <cstdint>
#include <string>

#include "body/procedural_body.h"
#include "io/motion.h"
#include "synth/synth_subject.h"

namespace haha {

// The body `haha synth` uses: `path` loaded when given, else the procedural body.
BodyModel synth_body(const std::string& path, BodyResolution resolution, uint64_t seed);

struct SynthSummary {
  Camera camera;
  int train_frames = 0, test_frames = 0, unseen_frames = 0;
  int texture_size = 0;
  double min_pose_gap = 0;  // measured min over (test, train) pairs of pose_distance
};

// Folder of the part masks beside images/ and masks/: DIR/part_masks/%06d.png, named as the
// frame's image, 8-bit single channel, the fraction of the pixel's subsamples whose visible
// surface is a garment around both legs (SynthMesh::garment: subject 1's skirt, subject 2's
// coat tails); 0 elsewhere, the body and the other pieces included.
constexpr const char* kSynthPartMaskDir = "part_masks";

// Renders the whole dataset into `dir` through DatasetWriter, plus dir/contact_sheet.png,
// dir/synth_texture.png (the body atlas: what an ideal learned texture holds), when
// `save_body` is set dir/body_model.npz (the body used) and when `part_masks` is set the
// part masks (above). With opt.unseen the unseen views (synth_subject.h SynthUnseenView) come
// last, split "unseen", each with its own camera (dataset.json then has per-frame cameras),
// and a row of their own on the contact sheet. All of it is assembled beside `dir` and moved into place at the end:
// a failure leaves `dir` untouched. An existing `dir` is replaced only if it is empty or
// holds a dataset.json. `log` (may be null) receives progress lines.
SynthSummary write_synth_dataset(const std::string& dir, const BodyModel& body, const SynthOptions& opt,
                                 bool save_body, void (*log)(const std::string&) = nullptr, bool part_masks = false);

// `haha synth --motion`: the same subject (opt's subject, seed, size, supersample, texture,
// view shading; the frame counts and fit noise are not used) in the poses of `motion`,
// every frame a test frame with exact fits, dataset.json's fps the motion's (synth_subject.h: make_synth_subject_scene,
// set_synth_scene_motion). A Z-up motion (AMASS) is first turned upright about the
// subject's rest pelvis (io/motion.h motion_to_y_up). Written as write_synth_dataset writes.
SynthSummary write_synth_motion_dataset(const std::string& dir, const BodyModel& body, const SynthOptions& opt,
                                        const Motion& motion, bool save_body, bool part_masks,
                                        void (*log)(const std::string&) = nullptr);

}  // namespace haha
