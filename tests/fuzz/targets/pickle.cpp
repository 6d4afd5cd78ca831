// Python pickles (io/pickle.h): the safe reader of X-Humans / SMPLify-X fits, and the
// numbers of every value of a top-level dict.
#include "fuzz_target.h"
#include "io/pickle.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  haha::fuzz::expect_result_or_error([&] {
    const haha::Pickle p = haha::Pickle::parse(data, size, "fuzz.pkl");
    for (const std::string& k : p.root().keys()) haha::fuzz::expect_result_or_error([&] { (void)p.numbers(k); });
  });
  return 0;
}

// The seeds are the test fixtures (tests/fixtures/pickle), copied by the build: pickles
// written by Python itself, which this project cannot produce.
void haha_fuzz_write_seeds(const std::filesystem::path&) {}
