// Where the trainer's per-step work runs. The step loop, the stage schedule, frame and
// background sampling, learning-rate schedules, the densify / prune decisions and the
// checkpoint format live once in Trainer::Impl (train/trainer_impl.h) and act on the host
// state; the CPU runs each stage's step there too (trainer_stage*.cpp). A device backend
// (the CUDA one: train/trainer_cuda.cpp) runs the steps on its own copy of the state and
// hands it back to the host whenever the shared code needs it (densification, pruning,
// a stage change, a checkpoint, the outputs).
#pragma once

#include <memory>
#include <string>

#include "train/image_loss.h"

namespace haha {

class TrainerDevice {
 public:
  virtual ~TrainerDevice() = default;
  // The host state is current (set-up, a stage change, a level change of coarse to fine, a
  // checkpoint restored): copy what stage s needs to the device (parameters, optimiser
  // moments, statistics, the frames when their size changed).
  virtual void begin_stage(int s) = 0;
  // One step of the current stage (the semantics of Trainer::Impl::step1/2/3); false:
  // non-finite, nothing was updated.
  virtual bool step(LossTerms& terms, std::string& event) = 0;
  // Device state -> host (parameters, optimiser moments, densification statistics).
  virtual void download() = 0;
  // Host state -> device, after the host changed it (densify, prune).
  virtual void upload() = 0;
};

}  // namespace haha
