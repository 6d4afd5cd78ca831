#include "train/train_frame.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "train/levels.h"

namespace haha {

TrainFrame make_train_frame(std::string name, const Camera& camera, const SmplxParams& params, const Image& rgb,
                            const Image& mask, int resolution) {
  TrainFrame t;
  t.name = std::move(name);
  t.camera = camera;
  t.params = params;
  if (rgb.channels != 3) fail(t.name, "expected an RGB image");
  if (mask.width != rgb.width || mask.height != rgb.height)
    fail(t.name, "the mask's size differs from the image's");
  t.rgb = rgb.data;
  t.mask.resize(size_t(mask.width) * mask.height);
  for (size_t p = 0; p < t.mask.size(); ++p) t.mask[p] = std::clamp(mask.data[p * size_t(mask.channels)], 0.0f, 1.0f);
  if (resolution <= 0 || std::max(rgb.width, rgb.height) == resolution) return t;
  t.camera.width = rgb.width;  // the image's size is what gets scaled
  t.camera.height = rgb.height;
  return downscale_train_frame(t, resolution);
}

std::vector<TrainFrame> hold_out_frames(std::vector<TrainFrame>& frames, int every, std::vector<size_t>* held) {
  std::vector<TrainFrame> kept, out;
  if (held) held->clear();
  for (size_t i = 0; i < frames.size(); ++i) {
    if (every >= 2 && (i + 1) % size_t(every) == 0) {
      out.push_back(std::move(frames[i]));
      if (held) held->push_back(i);
    } else {
      kept.push_back(std::move(frames[i]));
    }
  }
  frames = std::move(kept);
  return out;
}

}  // namespace haha
