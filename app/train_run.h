// `haha train`: the training driver (the trainer core in train/ reads and writes no
// files). It reads the dataset and body model, runs the three stages with progress lines,
// checkpoints, and writes the run directory (app/run_dir.h).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace haha {

struct TrainRunOptions {
  std::string data_dir, model_path, run_dir;
  std::string preset = "tiny";
  std::vector<std::string> overrides;  // key=value
  bool resume = false;
  std::string lpips_weights;           // optional file
  std::string device = "cpu";          // cpu, cuda or auto (train/device.h); not part of the run's config
  int64_t stop_after = -1;             // >= 0: stop (as if killed) after this many steps in total
  std::function<void(const std::string&)> log;  // progress lines (null: stdout)
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
