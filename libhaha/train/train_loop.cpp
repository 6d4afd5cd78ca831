#include "train/train_loop.h"

#include "train/progress.h"

namespace haha {

int64_t run_train_loop(Trainer& trainer, const TrainLoopHooks& hooks) {
  TrainProgress progress(trainer.config(), trainer.step_in_stage());
  int64_t steps_run = 0;
  while (!trainer.done()) {
    if (hooks.stop && hooks.stop(steps_run)) break;
    const StepReport r = trainer.step();
    ++steps_run;
    const bool stage_end = trainer.stage() != r.stage;
    progress.update(r, stage_end);
    if (hooks.print_line && hooks.print_line(r, stage_end)) {
      hooks.log(progress_line(r, progress.rate(), progress.eta()));
      if (!r.event.empty()) hooks.log("  " + r.event);
    }
    if (hooks.after_step) hooks.after_step(r, stage_end);
  }
  return steps_run;
}

}  // namespace haha
