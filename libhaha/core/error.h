// Errors at API boundaries. I/O and validation code throws haha::Error whose message
// already names the file (and key) and the problem in one line; the CLI prints it and
// exits non-zero. Hot kernels never throw.
#pragma once

#include <stdexcept>
#include <string>

namespace haha {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& msg) : std::runtime_error(msg) {}
};

// "path: message" or "path: key: message".
[[noreturn]] inline void fail(const std::string& where, const std::string& what) {
  throw Error(where + ": " + what);
}

}  // namespace haha
