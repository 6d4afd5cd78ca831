// What the tests of the `haha` command share: the executable built beside the test
// programs (build/cli/haha), running it, and reading back a file it wrote.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
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

// Runs `haha ARGS` with its output (stdout and stderr) in DIR/out.txt, read into *out;
// returns its exit status (-1 when it did not exit).
inline int run_haha(const std::string& args, const std::filesystem::path& dir, std::string* out) {
  const std::filesystem::path o = dir / "out.txt";
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + o.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  *out = slurp(o);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A path quoted for the shell.
inline std::string quoted(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

}  // namespace haha::test
