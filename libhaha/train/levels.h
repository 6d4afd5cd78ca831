// Coarse to fine: a stage's steps spread over the levels of an image pyramid (config
// sN.levels), and what changes size with the level: the frames and the texture.
//
// Level l of L has the side full / 2^(L-1-l), so the last level trains at the training
// resolution. A stage's level is a function of its step alone, so a run resumed from a
// checkpoint picks up the level it stopped at.
#pragma once

#include <string>
#include <vector>

#include "train/trainer.h"

namespace haha {

constexpr int kMaxLevels = 6;

struct LevelSchedule {
  std::vector<int> ends;  // level l runs the stage's steps [ends[l-1], ends[l]); ends.back() = steps
  int num_levels() const { return ends.empty() ? 1 : int(ends.size()); }
  int level_of(int step) const;  // 0 for an empty schedule; the last level from ends.back() on
};

// "6,3,1" (shares of the steps, coarsest level first; any positive scale) over `steps`
// steps; "" = one level. Throws haha::Error "config: <key>: <problem>" for text that is not
// a list of non-negative numbers with a positive sum, or more than kMaxLevels entries.
LevelSchedule make_level_schedule(const std::string& text, int steps, const std::string& key);

// The side of level `level` of `num_levels` whose finest side is `full` (at least 1).
int level_side(int full, int level, int num_levels);

// The frame resampled (area filter, rgb and mask; the mask clamped to [0, 1] again) so its
// longer side is `longer_side`, the camera scaled with it (core/camera.h: pixel-edge
// convention). As given when equal.
TrainFrame downscale_train_frame(const TrainFrame& f, int longer_side);

// A (size, size, 3) texture resampled bilinearly (render/texture.h conventions) to
// (new_size, new_size, 3): what the texture of a coarse level shows, on a finer grid.
std::vector<float> resample_texture(const std::vector<float>& tex, int size, int new_size);

}  // namespace haha
