// Helpers shared by the data_* tests: a per-test temporary directory, error checks and
// small deterministic fixtures.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "body/smplx_params.h"
#include "core/error.h"
#include "io/image.h"
#include "core/camera.h"
#include "support/expect_error.h"

namespace haha::testutil {
using haha::test::expect_error;

namespace fs = std::filesystem;

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("haha_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& rel) const { return (dir_ / rel).string(); }
  // Names of entries in the temporary directory that look like leftovers of a write.
  std::vector<std::string> leftovers() const {
    std::vector<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) {
      const std::string n = e.path().filename().string();
      if (n.find(".tmp-") != std::string::npos || n.find(".old-") != std::string::npos) out.push_back(e.path());
    }
    return out;
  }
  fs::path dir_;
};

// An 8-bit-exact RGB pattern that differs per frame.
inline Image rgb_pattern(int w, int h, int frame) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = float((x * 29 + y * 13 + c * 71 + frame * 53) % 256) / 255.0f;
  return img;
}

// A rectangle of ones on zeros, moving with the frame.
inline Image mask_pattern(int w, int h, int frame) {
  Image m(w, h, 1);
  for (int y = 2; y < h - 2; ++y)
    for (int x = 1 + frame % 2; x < w - 2; ++x) m.at(x, y, 0) = 1.0f;
  return m;
}

inline SmplxParams params_pattern(int frame) {
  SmplxParams p;
  for (size_t i = 0; i < p.pose.size(); ++i) p.pose[i] = 0.01f * float(int(i % 17) - 8) + 0.001f * float(frame);
  p.betas = {0.5f, -0.25f, 0.125f * float(frame)};
  p.expression = {0.1f, 0.2f};
  p.transl = {0.1f * float(frame), 0.2f, 3.0f};
  return p;
}

inline Camera camera_pattern(int w, int h, float tz = 3.0f) {
  Camera c;
  c.width = w;
  c.height = h;
  c.fx = 10.5f;
  c.fy = 11.25f;
  c.cx = 4.0f;
  c.cy = 6.25f;
  // A rotation about y by 0.3 rad.
  const float cs = std::cos(0.3f), sn = std::sin(0.3f);
  c.R = Mat3<float>::identity();
  c.R.a[0][0] = cs;
  c.R.a[0][2] = sn;
  c.R.a[2][0] = -sn;
  c.R.a[2][2] = cs;
  c.t = Vec3f(0.1f, -0.2f, tz);
  return c;
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}

inline std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

inline void replace_in_file(const std::string& path, const std::string& from, const std::string& to) {
  std::string t = read_text(path);
  const auto p = t.find(from);
  ASSERT_NE(p, std::string::npos) << from << " not in " << path;
  t.replace(p, from.size(), to);
  write_text(path, t);
}

inline void expect_same_params(const SmplxParams& a, const SmplxParams& b, float tol = 0.0f) {
  for (size_t i = 0; i < a.pose.size(); ++i) EXPECT_NEAR(a.pose[i], b.pose[i], tol) << "pose " << i;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a.transl[size_t(i)], b.transl[size_t(i)], tol);
  // Shorter vectors mean zeros beyond their end.
  for (size_t i = 0; i < std::max(a.betas.size(), b.betas.size()); ++i)
    EXPECT_NEAR(i < a.betas.size() ? a.betas[i] : 0.f, i < b.betas.size() ? b.betas[i] : 0.f, tol) << "beta " << i;
  for (size_t i = 0; i < std::max(a.expression.size(), b.expression.size()); ++i)
    EXPECT_NEAR(i < a.expression.size() ? a.expression[i] : 0.f, i < b.expression.size() ? b.expression[i] : 0.f, tol);
}

inline void expect_same_camera(const Camera& a, const Camera& b, float tol = 0.0f) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_NEAR(a.fx, b.fx, tol);
  EXPECT_NEAR(a.fy, b.fy, tol);
  EXPECT_NEAR(a.cx, b.cx, tol);
  EXPECT_NEAR(a.cy, b.cy, tol);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.R.a[i][j], b.R.a[i][j], tol);
    EXPECT_NEAR(a.t[i], b.t[i], tol);
  }
}

}  // namespace haha::testutil
