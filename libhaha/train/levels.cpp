#include "train/levels.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/error.h"
#include "core/image.h"
#include "render/texture.h"

namespace haha {

int LevelSchedule::level_of(int step) const {
  for (size_t l = 0; l < ends.size(); ++l)
    if (step < ends[l]) return int(l);
  return ends.empty() ? 0 : int(ends.size()) - 1;
}

LevelSchedule make_level_schedule(const std::string& text, int steps, const std::string& key) {
  LevelSchedule s;
  if (text.empty()) return s;
  std::vector<double> shares;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v) || v < 0)
      fail("config", key + ": expected comma-separated non-negative shares such as 6,3,1, got '" + text + "'");
    shares.push_back(v);
    pos = comma + 1;
  }
  if (int(shares.size()) > kMaxLevels)
    fail("config", key + ": at most " + std::to_string(kMaxLevels) + " levels, got " + std::to_string(shares.size()));
  double total = 0;
  for (double v : shares) total += v;
  if (!(total > 0)) fail("config", key + ": the shares must not all be 0");
  double cum = 0;
  for (double v : shares) {
    cum += v;
    s.ends.push_back(int(std::lround(double(steps) * cum / total)));
  }
  s.ends.back() = steps;
  return s;
}

int level_side(int full, int level, int num_levels) {
  const int shift = std::max(0, num_levels - 1 - level);
  return std::max(1, int(std::lround(double(full) / double(1 << shift))));
}

TrainFrame downscale_train_frame(const TrainFrame& f, int longer_side) {
  const int W = f.camera.width, H = f.camera.height;
  if (std::max(W, H) == longer_side) return f;
  const double s = double(longer_side) / double(std::max(W, H));
  const int nw = std::max(1, int(std::lround(W * s))), nh = std::max(1, int(std::lround(H * s)));
  TrainFrame t;
  t.name = f.name;
  t.params = f.params;
  t.camera = f.camera;
  Image rgb(W, H, 3), mask(W, H, 1);
  rgb.data = f.rgb;
  mask.data = f.mask;
  t.rgb = resize_area(rgb, nw, nh).data;
  t.mask = resize_area(mask, nw, nh).data;
  for (float& m : t.mask) m = std::clamp(m, 0.0f, 1.0f);  // an average of ones can round above 1
  const float sx = float(nw) / float(W), sy = float(nh) / float(H);
  t.camera.width = nw;
  t.camera.height = nh;
  t.camera.fx *= sx;
  t.camera.cx *= sx;
  t.camera.fy *= sy;
  t.camera.cy *= sy;
  return t;
}

std::vector<float> resample_texture(const std::vector<float>& tex, int size, int new_size) {
  if (new_size == size) return tex;
  const TextureView view{size, size, 3, tex.data()};
  std::vector<float> out(size_t(new_size) * new_size * 3);
  for (int j = 0; j < new_size; ++j)
    for (int i = 0; i < new_size; ++i) {
      const float u = (float(i) + 0.5f) / float(new_size), v = 1.0f - (float(j) + 0.5f) / float(new_size);
      bilinear_sample(view, u, v, &out[(size_t(j) * new_size + i) * 3]);
    }
  return out;
}

}  // namespace haha
