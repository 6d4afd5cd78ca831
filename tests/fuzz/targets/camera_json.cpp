// cam.json (io/camera_json.h).
#include "fuzz_target.h"
#include "io/camera_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  haha::fuzz::expect_result_or_error([&] { (void)haha::parse_camera_json(text, "fuzz/cam.json"); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const std::string full =
      R"({"width": 64, "height": 48, "K": [[60, 0, 32], [0, 60, 24], [0, 0, 1]],)"
      R"( "world_to_camera": [[1, 0, 0, 0], [0, -1, 0, 0.1], [0, 0, -1, 3], [0, 0, 0, 1]], "near": 0.01, "far": 100})";
  haha::fuzz::write_seed(dir, "full.json", std::vector<uint8_t>(full.begin(), full.end()));
  haha::Camera c;
  c.width = c.height = 16;
  c.fx = c.fy = 20;
  c.cx = c.cy = 8;
  const std::string written = haha::camera_to_json(c);
  haha::fuzz::write_seed(dir, "written.json", std::vector<uint8_t>(written.begin(), written.end()));
}
