// LPIPS weight files (app/lpips_weights.h) and the network built from them (train/lpips.h):
// a user-supplied .npz whose shapes decide every allocation of the network.
// links: haha_app
#include "app/lpips_weights.h"
#include "fuzz_target.h"
#include "io/npy.h"
#include "train/lpips.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, ".npz");
  haha::fuzz::expect_result_or_error([&] {
    const haha::LpipsWeights w = haha::read_lpips_weights(path);
    for (haha::LpipsBackbone b : {haha::LpipsBackbone::Alex, haha::LpipsBackbone::Vgg16}) {
      haha::fuzz::expect_result_or_error([&] {
        const haha::LpipsNet<float> net(w, b);
        (void)net.min_size();
      });
    }
  });
  return 0;
}

// Narrow networks of the real layouts (2 channels, 1 x 1 kernels; the real files are
// 10-60 MB): they build, so mutations reach the shape chain.
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed-lpips.npz").string();
  auto net = [&](const char* prefix, std::initializer_list<int> convs, const char* name) {
    haha::Npz z;
    int in = 3;
    for (int c : convs) {
      const std::string k = std::string(prefix) + ".features." + std::to_string(c);
      z.set(k + ".weight", haha::NpyArray::from(std::vector<float>(size_t(2 * in), 0.5f), {2, in, 1, 1}));
      z.set(k + ".bias", haha::NpyArray::from(std::vector<float>(2, 0.1f), {2}));
      in = 2;
    }
    for (int t = 0; t < 5; ++t)
      z.set(std::string(prefix) + ".lin." + std::to_string(t) + ".weight",
            haha::NpyArray::from(std::vector<float>(2, 1.0f), {1, 2, 1, 1}));
    z.write(p);
    haha::fuzz::write_seed(dir, name, haha::fuzz::file_bytes(p));
  };
  net("alex", {0, 3, 6, 8, 10}, "alex_narrow.npz");
  net("vgg", {0, 2, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28}, "vgg_narrow.npz");
  std::filesystem::remove(p);
}
