// What the tests of the `haha` command share: the executable built beside the test
// programs (build/cli/haha), and reading back a file it wrote.
#pragma once

#include <filesystem>
#include <fstream>
#include <cstdint>
#include <string>
#include <vector>

namespace haha::test {

inline const std::filesystem::path kHaha =
    std::filesystem::read_symlink("/proc/self/exe").parent_path().parent_path() / "cli" / "haha";

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

inline std::vector<uint8_t> slurp_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

}  // namespace haha::test
