// dataset.json of a native dataset (data/dataset.h), against a fixed set of frame files:
// the fuzzed bytes are the directory's dataset.json; images, masks and parameters are the
// seed dataset's, written once per process.
// links: haha_data
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "body/smplx_params.h"
#include "data/dataset.h"
#include "fuzz_target.h"
#include "io/image.h"
#include "io/smplx_params_io.h"
#include "core/camera.h"

namespace {

namespace fs = std::filesystem;

// A two-frame dataset at 8 x 6 written through DatasetWriter (the real layout), removed
// at exit.
struct SeedDataset {
  fs::path dir;
  ~SeedDataset() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

fs::path seed_dataset() {
  static const SeedDataset seed{[] {
    const fs::path d = fs::temp_directory_path() / ("haha-fuzz-dataset-" + std::to_string(::getpid()));
    fs::remove_all(d);
    haha::DatasetWriter w(d.string(), 8, 6, 30.0, "neutral", "fuzz seed");
    for (int i = 0; i < 2; ++i) {
      haha::DatasetFrame f;
      f.camera.width = 8;
      f.camera.height = 6;
      f.camera.fx = f.camera.fy = 10;
      f.camera.cx = 4;
      f.camera.cy = 3;
      f.split = i == 0 ? haha::Split::train : haha::Split::test;
      f.params.pose[4] = 0.1f * float(i);
      haha::Image rgb(8, 6, 3), mask(8, 6, 1);
      for (size_t k = 0; k < rgb.data.size(); ++k) rgb.data[k] = float(k % 7) / 7.0f;
      for (size_t k = 0; k < mask.data.size(); ++k) mask.data[k] = float(k % 2);
      w.add(f, rgb, mask);
    }
    w.finish();
    return d;
  }()};
  return seed.dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path dir = seed_dataset();
  std::ofstream(dir / "dataset.json", std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), std::streamsize(size));
  haha::fuzz::expect_result_or_error([&] { (void)haha::read_dataset(dir.string(), haha::LoadPixels::headers); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const std::vector<uint8_t> written = haha::fuzz::file_bytes((seed_dataset() / "dataset.json").string());
  haha::fuzz::write_seed(dir, "written.json", written);
  // The same frames with a camera per frame and the true fits named too.
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(written);
  for (auto& f : j["frames"]) f["camera"] = j["camera"];
  j.erase("camera");
  j["smplx_true"] = j["smplx"];
  const std::string per_frame = j.dump(1);
  haha::fuzz::write_seed(dir, "per_frame_cameras.json", std::vector<uint8_t>(per_frame.begin(), per_frame.end()));
}
