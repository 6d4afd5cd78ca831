// File side of `haha train` (the trainer core in train/ reads and writes no files): the
// run directory, the resolved config as JSON, checkpoints as npz, dataset frames turned
// into training frames, and the training driver with progress lines.
//
// RUN/ layout:
//   config.json              {"format": "haha-run", "version": 1, "model": ABS_PATH,
//                             "data": ABS_PATH, "lpips_weights": PATH|null,
//                             "config": {every TrainConfig key: value}}
//   checkpoint.npz           latest state (atomic; --resume continues from it)
//   checkpoint_stage{1,2,3}.npz  state at each stage end
//   avatar.npz               the HAHA avatar (filtered Gaussians + texture; format/avatar_npz.h)
//   avatar_stage1.npz        the full-Gaussian avatar of stage 1 with the final texture
//   smplx_refined.npz        the refined per-frame fits of the training frames
//   train_summary.json       stage wall times, Gaussian counts, skipped steps, last losses
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "data/dataset.h"
#include "train/config.h"
#include "train/trainer.h"

namespace haha {

// ---- config.json ------------------------------------------------------------------------
struct RunInfo {
  std::string model_path;          // absolute
  std::string data_path;           // absolute
  std::string lpips_weights_path;  // empty = none
  TrainConfig config;
};
std::string run_info_to_json(const RunInfo& info);
// Throws haha::Error "<path>: <key>: <problem>".
RunInfo read_run_info(const std::string& path);
void write_run_info(const std::string& path, const RunInfo& info);  // atomic

// Stage wall times from RUN/train_summary.json ({0, 0, 0} when the file is absent).
std::array<double, 3> read_train_seconds(const std::string& run_dir);

// ---- checkpoints ------------------------------------------------------------------------
void write_checkpoint(const std::string& path, const TrainCheckpoint& ck);  // atomic npz
TrainCheckpoint read_checkpoint(const std::string& path);  // haha::Error naming the file

// ---- frames -------------------------------------------------------------------------------
// Whether the dataset's images are already composited on black with soft masks: "true" /
// "false", or "auto" = datasets written by `haha synth` (their source says so).
bool dataset_premultiplied(const Dataset& ds, const std::string& setting);

// The frames of one split as training frames, resized so the longer side is `resolution`
// (0 = as stored; cameras scaled with the images). Loads pixels that are not loaded yet.
// Throws haha::Error naming the file for unreadable images.
std::vector<TrainFrame> dataset_frames(Dataset& ds, Split split, int resolution);

// ---- the driver -------------------------------------------------------------------------
struct TrainRunOptions {
  std::string data_dir, model_path, run_dir;
  std::string preset = "tiny";
  std::vector<std::string> overrides;  // key=value
  bool resume = false;
  std::string lpips_weights;           // optional file
  int64_t stop_after = -1;             // >= 0: stop (as if killed) after this many steps in total
  std::function<void(const std::string&)> log;  // progress lines (null: stdout)
  // Writes an avatar file (format/avatar_npz.h save_avatar_npz); the data layer does not
  // link the format layer, the caller supplies it.
  std::function<void(const Avatar&, const std::string&)> save_avatar;
};

struct TrainRunResult {
  bool finished = false;   // all three stages done
  int64_t steps_run = 0;   // steps run by this call
  int gaussians = 0;
  int gaussians_stage1 = 0;
  std::array<double, 3> stage_seconds{0, 0, 0};
};

// Validates the dataset (every frame read and checked BEFORE training), sets up or resumes
// the run, trains with progress lines, checkpoints at intervals and stage ends, and writes
// the run outputs at the end.
TrainRunResult run_training(const TrainRunOptions& opt);

}  // namespace haha
