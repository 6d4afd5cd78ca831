#include "app/train_frames.h"

#include "train/train_frame.h"

namespace haha {

bool dataset_premultiplied(const Dataset& ds, const std::string& setting) {
  // dataset.json's flag; files from before it: as they were read then.
  const bool flag = ds.premultiplied >= 0 ? ds.premultiplied == 1 : ds.source.rfind("haha synth", 0) == 0;
  return resolve_premultiplied(setting, flag);
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
