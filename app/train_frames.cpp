#include "app/train_frames.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "io/image.h"

namespace haha {

bool dataset_premultiplied(const Dataset& ds, const std::string& setting) {
  if (setting == "true") return true;
  if (setting == "false") return false;
  if (ds.premultiplied >= 0) return ds.premultiplied == 1;  // dataset.json says
  return ds.source.rfind("haha synth", 0) == 0;  // files from before the flag: as they were read then
}

std::vector<TrainFrame> dataset_frames(Dataset& ds, Split split, int resolution) {
  std::vector<TrainFrame> out;
  for (int i : ds.indices(split)) {
    ds.load_frame(i);
    DatasetFrame& f = ds.frames[size_t(i)];
    TrainFrame t;
    t.name = f.image_path.empty() ? ds.path + ": frame " + std::to_string(i) : f.image_path;
    t.camera = f.camera;
    t.params = f.params;
    Image rgb = f.image, mask = f.mask;
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
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace haha
