#include "train/train_frame.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {

TrainFrame make_train_frame(std::string name, const Camera& camera, const SmplxParams& params, const Image& rgb_in,
                            const Image& mask_in, int resolution) {
  TrainFrame t;
  t.name = std::move(name);
  t.camera = camera;
  t.params = params;
  Image rgb = rgb_in, mask = mask_in;
  const int W = rgb.width, H = rgb.height;
  if (resolution > 0 && std::max(W, H) != resolution) {
    const double s = double(resolution) / double(std::max(W, H));
    const int nw = std::max(1, int(std::lround(W * s))), nh = std::max(1, int(std::lround(H * s)));
    rgb = resize_area(rgb, nw, nh);
    mask = resize_area(mask, nw, nh);
    const float sx = float(nw) / float(W), sy = float(nh) / float(H);
    t.camera.width = nw;
    t.camera.height = nh;
    t.camera.fx *= sx;
    t.camera.cx *= sx;
    t.camera.fy *= sy;
    t.camera.cy *= sy;
  }
  if (rgb.channels != 3) fail(t.name, "expected an RGB image");
  t.rgb = std::move(rgb.data);
  t.mask.resize(size_t(mask.width) * mask.height);
  for (size_t p = 0; p < t.mask.size(); ++p) t.mask[p] = std::clamp(mask.data[p * size_t(mask.channels)], 0.0f, 1.0f);
  return t;
}

}  // namespace haha
