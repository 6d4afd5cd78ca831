// Images through the image layer (io/image.h, OpenImageIO): PNG, JPEG, TIFF and EXR,
// chosen by the input's magic bytes (as the file would be named).
#include <cstring>

#include "fuzz_target.h"
#include "io/image.h"

namespace {

std::string extension_of(const uint8_t* d, size_t n) {
  if (n >= 4 && std::memcmp(d, "\x89PNG", 4) == 0) return ".png";
  if (n >= 2 && d[0] == 0xFF && d[1] == 0xD8) return ".jpg";
  if (n >= 4 && (std::memcmp(d, "II*\0", 4) == 0 || std::memcmp(d, "MM\0*", 4) == 0)) return ".tif";
  if (n >= 4 && std::memcmp(d, "\x76\x2f\x31\x01", 4) == 0) return ".exr";
  return ".png";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, extension_of(data, size));
  haha::fuzz::expect_result_or_error([&] { (void)haha::read_image(path); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  haha::Image img(6, 5, 3);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = float(i % 7) / 6.0f;
  for (const char* ext : {".png", ".jpg", ".tif", ".exr"}) {
    const std::string p = (std::filesystem::temp_directory_path() / (std::string("haha-fuzz-seed") + ext)).string();
    haha::write_image(p, img);
    haha::fuzz::write_seed(dir, std::string("rgb") + ext, haha::fuzz::file_bytes(p));
    std::filesystem::remove(p);
  }
  haha::Image grey(4, 4, 1);
  grey.data.assign(16, 0.5f);
  const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed-grey.png").string();
  haha::write_image(p, grey);
  haha::fuzz::write_seed(dir, "grey.png", haha::fuzz::file_bytes(p));
  std::filesystem::remove(p);
}
