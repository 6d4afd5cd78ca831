// What the runtime's tests run on: a small packed avatar and a 3-frame AMASS-style motion
// (the layout `haha motion` writes) in a temporary folder, random poses and a front camera.
#pragma once

#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <system_error>
#include <vector>

#include "format/avatar_pack.h"
#include "haha/haha_runtime.h"
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

// Runs a shell command; returns its exit status, stdout+stderr in *out.
inline int sh(const std::string& cmd, std::string* out) {
  out->clear();
  FILE* p = popen(("(" + cmd + ") 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out->append(buf, n);
  return pclose(p);
}

// A path quoted for the shell.
inline std::string q(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

inline std::array<float, 165> random_pose(uint32_t seed, float amplitude) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, amplitude);
  std::array<float, 165> p{};
  for (float& x : p) x = n(rng);
  return p;
}

// Front camera at z = 3 looking at the origin (OpenCV: y down).
inline haha_camera front_camera(int w, int h) {
  haha_camera c{};
  c.width = w, c.height = h;
  c.fx = c.fy = 1.25f * float(h);
  c.cx = 0.5f * float(w), c.cy = 0.5f * float(h);
  const float R[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1};
  std::memcpy(c.rotation, R, sizeof R);
  c.translation[2] = 3;
  return c;
}

}  // namespace haha::test
