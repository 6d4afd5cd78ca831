// Output directories assembled beside their final place and moved in at the end, so a failed
// command leaves the previous output (or nothing) instead of a half-written one.
#pragma once

#include <string>

namespace haha {

// Whether `dir` may be replaced by a dataset: missing, an empty directory, or one holding a
// dataset.json (a previous dataset).
bool dataset_dir_replaceable(const std::string& dir);

// Moves the finished directory `stage` to `dir`. An existing `dir` must be replaceable
// (above); it is moved aside first and removed once `stage` is in place, and put back if
// the move fails. Throws haha::Error naming `dir`.
void move_dir_into_place(const std::string& stage, const std::string& dir);

// Removes a directory (recursively) on scope exit unless released.
struct DirGuard {
  std::string path;
  bool armed = true;
  explicit DirGuard(std::string p) : path(std::move(p)) {}
  DirGuard(const DirGuard&) = delete;
  DirGuard& operator=(const DirGuard&) = delete;
  ~DirGuard();
  void release() { armed = false; }
};

}  // namespace haha
