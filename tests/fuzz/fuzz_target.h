// What every fuzz target shares. A target defines
//   extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
//   void haha_fuzz_write_seeds(const std::filesystem::path& dir);  // valid inputs to start from
// Any input must end in a result or a haha::Error: the target swallows haha::Error only, so
// another exception, a crash, a hang or a sanitizer report is a finding. The same file is
// built twice: against libFuzzer with clang (scripts/fuzz.sh) and against replay_main.cpp
// with the default compiler, which runs the committed corpus in every test run.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"

void haha_fuzz_write_seeds(const std::filesystem::path& dir);

namespace haha::fuzz {

// Runs f; a haha::Error is the expected answer to a bad input.
template <class F>
void expect_result_or_error(F&& f) {
  try {
    f();
  } catch (const haha::Error&) {
  }
}

// The files as_file() made, removed when the process ends normally.
struct TempFiles {
  std::vector<std::string> paths;
  ~TempFiles() {
    std::error_code ec;
    for (const std::string& p : paths) std::filesystem::remove(p, ec);
  }
};

// The bytes as a file (the readers that take paths): one per process and extension,
// rewritten per input.
inline std::string as_file(const uint8_t* data, size_t size, const std::string& extension) {
  static TempFiles made;
  const std::string path =
      (std::filesystem::temp_directory_path() / ("haha-fuzz-" + std::to_string(::getpid()) + extension)).string();
  if (std::find(made.paths.begin(), made.paths.end(), path) == made.paths.end()) made.paths.push_back(path);
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return path;
}

inline void write_seed(const std::filesystem::path& dir, const std::string& name, const std::vector<uint8_t>& bytes) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

}  // namespace haha::fuzz
