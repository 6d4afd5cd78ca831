// The trained avatar as an .npz (format/avatar_npz.h): every field round-trips, files
// written before the depth margin existed still read, bad values name the file and key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "format/avatar_npz.h"
#include "io/npy.h"
#include "support/expect_error.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

std::string tmp(const std::string& name) {
  return (fs::temp_directory_path() / ("haha_avatar_npz_" + std::to_string(::getpid()) + "_" + name)).string();
}

TEST(AvatarNpz, EveryFieldRoundTrips) {
  Avatar a = test::make_test_avatar(40);
  a.depth_margin = 0.015f;
  const std::string p = tmp("a.npz");
  save_avatar_npz(a, p);
  const Avatar b = load_avatar_npz(p);
  EXPECT_EQ(b.betas, a.betas);
  EXPECT_EQ(b.expression, a.expression);
  EXPECT_EQ(b.face_scale_divisor, a.face_scale_divisor);
  EXPECT_EQ(b.depth_margin, a.depth_margin);
  EXPECT_EQ(b.texture.width, a.texture.width);
  EXPECT_EQ(b.texture.rgb, a.texture.rgb);
  EXPECT_EQ(b.gaussians.face, a.gaussians.face);
  EXPECT_EQ(b.gaussians.offset, a.gaussians.offset);
  EXPECT_EQ(b.gaussians.rotation, a.gaussians.rotation);
  EXPECT_EQ(b.gaussians.scale, a.gaussians.scale);
  EXPECT_EQ(b.gaussians.color, a.gaussians.color);
  EXPECT_EQ(b.gaussians.opacity, a.gaussians.opacity);
  EXPECT_TRUE(b.body.faces.empty());  // the body model is the run's, not the file's
  fs::remove(p);
}

TEST(AvatarNpz, FilesWithoutADepthMarginReadAsTheExactTest) {
  Avatar a = test::make_test_avatar(10);
  a.depth_margin = 0.5f;
  const std::string p = tmp("old.npz");
  save_avatar_npz(a, p);
  Npz z = Npz::read(p);
  Npz without(p);
  for (const std::string& k : z.keys())
    if (k != "depth_margin") without.set(k, z.get(k));
  without.write(p);
  EXPECT_EQ(load_avatar_npz(p).depth_margin, 0.0f);
  fs::remove(p);
}

TEST(AvatarNpz, BadDepthMarginNamesTheFileAndKey) {
  Avatar a = test::make_test_avatar(10);
  const std::string p = tmp("bad.npz");
  a.depth_margin = std::nanf("");
  test::expect_error([&] { save_avatar_npz(a, p); }, {p, "depth_margin"});
  a.depth_margin = 2.0f;
  test::expect_error([&] { save_avatar_npz(a, p); }, {p, "depth_margin", "[-1, 1]"});
  EXPECT_FALSE(fs::exists(p));
}

}  // namespace
}  // namespace haha
