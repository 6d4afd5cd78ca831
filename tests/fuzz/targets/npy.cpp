// One .npy buffer (io/npy.h parse_npy), every dtype converted.
#include "fuzz_target.h"
#include "io/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  haha::fuzz::expect_result_or_error([&] {
    const haha::NpyArray a = haha::parse_npy(data, size, "fuzz.npy");
    if (a.dtype != haha::DType::unsupported) {
      (void)a.as_double();
      haha::fuzz::expect_result_or_error([&] { (void)a.as_int32(); });
    }
  });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  using haha::NpyArray;
  haha::fuzz::write_seed(dir, "f32.npy", haha::serialize_npy(NpyArray::from(std::vector<float>{1, -2, 3.5f, 4, 5, 6}, {2, 3})));
  haha::fuzz::write_seed(dir, "f64.npy", haha::serialize_npy(NpyArray::from(std::vector<double>{1e-300, 2}, {2})));
  haha::fuzz::write_seed(dir, "i32.npy", haha::serialize_npy(NpyArray::from(std::vector<int32_t>{-7, 8, 9}, {3, 1})));
  haha::fuzz::write_seed(dir, "i64.npy", haha::serialize_npy(NpyArray::from(std::vector<int64_t>{int64_t(1) << 40}, {})));
}
