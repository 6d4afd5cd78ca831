#include "data/stage_dir.h"

#include <unistd.h>

#include <filesystem>

#include "core/error.h"

namespace haha {

namespace fs = std::filesystem;

bool dataset_dir_replaceable(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return true;
  if (!fs::is_directory(dir, ec)) return false;
  return fs::is_empty(dir, ec) || fs::is_regular_file(fs::path(dir) / "dataset.json", ec);
}

void move_dir_into_place(const std::string& stage, const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    fs::rename(stage, dir, ec);
    if (ec) fail(dir, "cannot move the finished dataset into place: " + ec.message());
    return;
  }
  if (!dataset_dir_replaceable(dir)) fail(dir, "exists, is not empty and holds no dataset.json: refusing to replace it");
  const fs::path old = dir + ".old-" + std::to_string(::getpid());
  fs::remove_all(old, ec);
  fs::rename(dir, old, ec);
  if (ec) fail(dir, "cannot move the previous dataset aside: " + ec.message());
  fs::rename(stage, dir, ec);
  if (ec) {
    std::error_code ec2;
    fs::rename(old, dir, ec2);
    fail(dir, "cannot move the finished dataset into place: " + ec.message());
  }
  fs::remove_all(old, ec);
}

DirGuard::~DirGuard() {
  if (armed) {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
}

}  // namespace haha
