// Motion files (io/motion.h): AMASS-style and native SMPL-X parameter .npz.
#include "fuzz_target.h"
#include "io/motion.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, ".npz");
  haha::fuzz::expect_result_or_error([&] { (void)haha::read_motion(path); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed-motion.npz").string();
  for (int width : {165, 156}) {
    haha::Npz z;
    z.set("poses", haha::NpyArray::from(std::vector<float>(size_t(2) * width, 0.1f), {2, width}));
    z.set("trans", haha::NpyArray::from(std::vector<float>(6, 0.0f), {2, 3}));
    z.set(width == 165 ? "mocap_frame_rate" : "mocap_framerate", haha::NpyArray::from(std::vector<double>{30.0}, {}));
    z.write(p);
    haha::fuzz::write_seed(dir, width == 165 ? "amass_smplx.npz" : "amass_smplh.npz", haha::fuzz::file_bytes(p));
  }
  std::vector<haha::SmplxParams> frames(2);
  frames[1].pose[5] = 0.3f;
  frames[1].betas = {0.1f, -0.2f};
  haha::write_smplx_params(p, frames);
  haha::fuzz::write_seed(dir, "native.npz", haha::fuzz::file_bytes(p));
  std::filesystem::remove(p);
}
