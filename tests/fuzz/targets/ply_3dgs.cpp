// A standard 3DGS .ply (io/ply_3dgs.h), binary and ASCII, and its activation.
#include "fuzz_target.h"
#include "io/ply_3dgs.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, ".ply");
  haha::fuzz::expect_result_or_error([&] { (void)haha::activate(haha::read_ply_3dgs(path)); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  for (int degree : {0, 1}) {
    haha::GaussianPly g;
    g.sh_degree = degree;
    const int n = 3, k = (degree + 1) * (degree + 1);
    g.means = {0, 0, 1, 0.1f, 0, 1, 0, 0.1f, 1};
    g.sh.assign(size_t(n) * k * 3, 0.25f);
    g.opacity_logit = {0.5f, -1, 2};
    g.log_scales.assign(3 * n, -3.0f);
    g.quats = {1, 0, 0, 0, 0.7f, 0.7f, 0, 0, 1, 0, 0, 0};
    for (bool ascii : {false, true}) {
      const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed.ply").string();
      haha::write_ply_3dgs(p, g, ascii);
      haha::fuzz::write_seed(dir, "deg" + std::to_string(degree) + (ascii ? "_ascii.ply" : "_binary.ply"),
                             haha::fuzz::file_bytes(p));
      std::filesystem::remove(p);
    }
  }
}
