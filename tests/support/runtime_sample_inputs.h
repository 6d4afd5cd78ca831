// What the runtime's sample tests (samples/c, cpp, csharp) run on: a small packed avatar and
// a 3-frame AMASS-style motion (the layout `haha motion` writes), in a temporary folder.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "format/avatar_pack.h"
#include "io/npy.h"
#include "support/format_test_avatar.h"

namespace haha::test {

// A fresh folder under the system's temporary directory, removed again at scope exit.
struct SampleTempDir {
  std::filesystem::path path;
  explicit SampleTempDir(const std::string& name)
      : path(std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~SampleTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

inline void write_sample_inputs(const std::filesystem::path& glb, const std::filesystem::path& motion) {
  write_avatar_glb(make_test_avatar(300), glb.string(), PackOptions{});
  const int T = 3;
  std::vector<float> poses(size_t(T) * 165, 0.0f), trans(size_t(T) * 3, 0.0f);
  for (int t = 0; t < T; ++t) {
    poses[size_t(t) * 165 + 3 * 16 + 2] = -0.5f * float(t);  // left shoulder down
    poses[size_t(t) * 165 + 1] = 0.3f * float(t);            // turn
    trans[size_t(t) * 3] = 0.05f * float(t);
  }
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, 165}));
  z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{30.0}, {}));
  z.write(motion.string());
}

}  // namespace haha::test
