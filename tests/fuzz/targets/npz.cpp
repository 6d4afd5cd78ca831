// An .npz archive (io/npy.h Npz::read: libzip + every member's .npy).
#include "fuzz_target.h"
#include "io/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, ".npz");
  haha::fuzz::expect_result_or_error([&] {
    const haha::Npz z = haha::Npz::read(path);
    for (const std::string& k : z.keys()) haha::fuzz::expect_result_or_error([&] { (void)z.get(k).as_float(); });
  });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  haha::Npz z;
  z.set("poses", haha::NpyArray::from(std::vector<float>(2 * 6, 0.5f), {2, 6}));
  z.set("faces", haha::NpyArray::from(std::vector<int32_t>{0, 1, 2}, {1, 3}));
  z.set("rate", haha::NpyArray::from(std::vector<double>{30.0}, {}));
  const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed.npz").string();
  z.write(p);
  haha::fuzz::write_seed(dir, "small.npz", haha::fuzz::file_bytes(p));
  std::filesystem::remove(p);
}
