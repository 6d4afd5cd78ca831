// The step loop every training driver runs (`haha train`'s app/train_run.cpp and
// tools/train_bench): Trainer::step until the run is done or the driver stops it, the
// progress line (train/progress.h) and the step's event line whenever the driver asks for
// them, and the driver's own work after each step (checkpoints, per-stage figures).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "train/trainer.h"

namespace haha {

struct TrainLoopHooks {
  // Before each step, with the steps run so far in this loop: true ends the loop (a step
  // budget). May throw to abandon the run (an interrupt, after saving what it must).
  std::function<bool(int64_t steps_run)> stop;
  // After each step: whether to print its progress line (and its event, if any).
  std::function<bool(const StepReport& r, bool stage_end)> print_line;
  // Where the lines go, one line per call without its newline. Required.
  std::function<void(const std::string& line)> log;
  // After each step and its lines; `stage_end`: the step finished its stage.
  std::function<void(const StepReport& r, bool stage_end)> after_step;
};

// Runs the loop from the trainer's current state; returns the number of steps run. The
// progress clock starts at the trainer's current step (a resumed run).
int64_t run_train_loop(Trainer& trainer, const TrainLoopHooks& hooks);

}  // namespace haha
