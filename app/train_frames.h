// Dataset frames turned into the trainer's frames (train/trainer.h TrainFrame), shared by
// the train, eval and bench drivers.
#pragma once

#include <string>
#include <vector>

#include "data/dataset.h"
#include "train/trainer.h"

namespace haha {

// Whether the dataset's images are already composited on black with soft masks: "true" /
// "false", or "auto" = dataset.json's "premultiplied" flag; files without it (written
// before the flag) count as premultiplied when `haha synth` wrote them (their source says so).
bool dataset_premultiplied(const Dataset& ds, const std::string& setting);

// The frames of one split as training frames, resized so the longer side is `resolution`
// (0 = as stored; cameras scaled with the images). Loads pixels that are not loaded yet.
// Throws haha::Error naming the file for unreadable images.
std::vector<TrainFrame> dataset_frames(Dataset& ds, Split split, int resolution);

// The longer side a run with config `c` trains at on this dataset (train/config.h
// train_resolution of the dataset's size).
int dataset_train_resolution(const Dataset& ds, const TrainConfig& c);

// The longer side `haha eval` / `haha bench` score at: `requested` (--resolution) when > 0,
// else the run's training size. Throws haha::Error "--resolution: ..." outside 0 or 16..8192.
int scoring_resolution(const Dataset& ds, const TrainConfig& c, int requested);

}  // namespace haha
