// Progress of a training run for its log lines (`haha train`, train_bench): the step rate of
// the current stage and a rough estimate of the time left.
#pragma once

#include <array>
#include <chrono>
#include <string>
#include <vector>

#include "train/config.h"
#include "train/trainer.h"

namespace haha {

// "42s", "3m05s", "1h02m"; "?" for a negative or non-finite value.
std::string format_duration(double seconds);

class TrainProgress {
 public:
  // Starts the clock of the current stage, `done_in_stage` of whose steps are already done
  // (a resumed run).
  TrainProgress(const TrainConfig& config, int done_in_stage);
  // After every step with its report; `stage_end`: the step finished its stage (the clock
  // restarts for the next one).
  void update(const StepReport& r, bool stage_end);
  double rate() const { return rate_; }  // steps per second in the reported step's stage
  double eta() const { return eta_; }    // seconds left in the whole run; NaN before a rate

 private:
  // Work of stage s's steps [a, b): one unit per step at full size; coarse-to-fine levels
  // cost by their pixel count plus a fixed part (train/levels.h).
  double work(int s, int a, int b) const;
  std::array<int, 3> steps_;
  std::array<std::vector<double>, 3> work_before_;  // per stage: work of its first k steps, k = 0..steps
  std::chrono::steady_clock::time_point stage_start_;
  int started_at_ = 0;  // completed steps of the stage when its clock started
  double rate_ = 0, eta_ = 0;
};

// "[stage 1] 120/3000 loss 0.01234 (l2 0.011 ssim 0.12 ...) G 20908 | 3.10 it/s | ETA 12m30s",
// the loss terms that are not zero, and " | SKIPPED (non-finite)" for a skipped step.
std::string progress_line(const StepReport& r, double rate, double eta);

}  // namespace haha
