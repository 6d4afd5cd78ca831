#include "app/train_frames.h"

#include <algorithm>

#include "core/error.h"

#include "train/train_frame.h"

namespace haha {

bool dataset_premultiplied(const Dataset& ds, const std::string& setting) {
  // dataset.json's flag; files from before it: as they were read then.
  const bool flag = ds.premultiplied >= 0 ? ds.premultiplied == 1 : ds.source.rfind("haha synth", 0) == 0;
  return resolve_premultiplied(setting, flag);
}

int dataset_train_resolution(const Dataset& ds, const TrainConfig& c) {
  return train_resolution(c, std::max(ds.width, ds.height));
}

int scoring_resolution(const Dataset& ds, const TrainConfig& c, int requested) {
  if (requested != 0 && (requested < 16 || requested > 8192)) fail("--resolution", "must be 0 or in 16..8192");
  return requested > 0 ? requested : dataset_train_resolution(ds, c);
}

std::vector<TrainFrame> dataset_frames(Dataset& ds, Split split, int resolution) {
  std::vector<TrainFrame> out;
  for (int i : ds.indices(split)) {
    ds.load_frame(i);
    const DatasetFrame& f = ds.frames[size_t(i)];
    out.push_back(make_train_frame(f.image_path.empty() ? ds.path + ": frame " + std::to_string(i) : f.image_path,
                                   f.camera, f.params, f.image, f.mask, resolution));
  }
  return out;
}

}  // namespace haha
