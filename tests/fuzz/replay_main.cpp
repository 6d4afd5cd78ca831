// The default-compiler driver of a fuzz target: runs every file of the given corpus
// folders (or files) through LLVMFuzzerTestOneInput, so the seed corpus and every input
// that ever failed run in every test run (CTest label `fuzz`). A finding terminates the
// program (uncaught exception or crash) and fails the test.
//   fuzz_replay_<target> CORPUS_DIR...         replay
//   fuzz_replay_<target> --write-seeds DIR     write the target's seed inputs
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <vector>

#include "fuzz_target.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  if (argc == 3 && std::strcmp(argv[1], "--write-seeds") == 0) {
    haha_fuzz_write_seeds(argv[2]);
    return 0;
  }
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i) {
    if (fs::is_directory(argv[i])) {
      for (const auto& e : fs::recursive_directory_iterator(argv[i]))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else if (fs::is_regular_file(argv[i])) {
      inputs.push_back(argv[i]);
    } else {
      std::fprintf(stderr, "replay: %s: no such file or folder\n", argv[i]);
      return 2;
    }
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "replay: no inputs (give corpus folders or files)\n");
    return 2;
  }
  for (const fs::path& p : inputs) {
    std::printf("replay %s\n", p.c_str());
    std::fflush(stdout);
    const std::vector<uint8_t> b = haha::fuzz::file_bytes(p.string());
    LLVMFuzzerTestOneInput(b.data(), b.size());
  }
  std::printf("replayed %zu inputs without a finding\n", inputs.size());
  return 0;
}
