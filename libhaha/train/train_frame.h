// Frames of images in memory turned into the trainer's frames (train/trainer.h TrainFrame):
// what every driver does with a dataset's pixels (app/train_frames.h reads them from files,
// tools/train_bench renders them).
#pragma once

#include <string>

#include "body/smplx_params.h"
#include "core/image.h"
#include "core/camera.h"
#include "train/trainer.h"

namespace haha {

// The frame resized (area filter, both images) so the longer side is `resolution` (0 or
// already so: as given), the camera scaled with it; the mask is the first channel clamped
// to [0, 1]. Throws haha::Error "<name>: expected an RGB image" for rgb without 3 channels.
TrainFrame make_train_frame(std::string name, const Camera& camera, const SmplxParams& params, const Image& rgb,
                            const Image& mask, int resolution);

// Moves every `every`-th frame (the last of each run of `every`) out of `frames` and returns
// them, in order; `held` (when given) receives their indices in the original order. No frame
// is held when there are fewer than `every` (at least every - 1 stay for training).
std::vector<TrainFrame> hold_out_frames(std::vector<TrainFrame>& frames, int every, std::vector<size_t>* held);

}  // namespace haha
