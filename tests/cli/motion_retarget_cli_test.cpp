// `haha motion --in M.npz --out M.bvh` and `haha motion --retarget M.bvh`: the round trip
// through the command gives the motion back, the map line says what was matched, and bad
// input is one error line with exit code 1.
#include <gtest/gtest.h>

#include <filesystem>

#include "body/rotation.h"
#include "io/motion.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::run_haha;

struct MotionRetargetCli : ::testing::Test {
  fs::path dir = fs::temp_directory_path() / ("haha-retarget-cli-" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir); }
  void TearDown() override { fs::remove_all(dir); }
};

TEST_F(MotionRetargetCli, BvhRoundTrip) {
  std::string out;
  ASSERT_EQ(run_haha("motion --kind walk --frames 24 --out " + quoted(dir / "a.npz"), dir, &out), 0) << out;
  ASSERT_EQ(run_haha("motion --in " + quoted(dir / "a.npz") + " --out " + quoted(dir / "a.bvh"), dir, &out), 0) << out;
  EXPECT_NE(out.find("centimetres"), std::string::npos) << out;
  ASSERT_EQ(run_haha("motion --retarget " + quoted(dir / "a.bvh") + " --out " + quoted(dir / "b.npz"), dir, &out), 0) << out;
  EXPECT_NE(out.find("map 'smplx': 55 of 55 SMPL-X joints matched (22 of 22 body joints); at rest: none"), std::string::npos) << out;
  const Motion a = read_motion((dir / "a.npz").string()), b = read_motion((dir / "b.npz").string());
  ASSERT_EQ(a.frames.size(), b.frames.size());
  EXPECT_NEAR(a.fps, b.fps, 1e-3);
  double worst = 0;
  for (size_t t = 0; t < a.frames.size(); ++t)
    for (int j = 0; j < kNumJoints; ++j) {
      const auto R = [j](const SmplxParams& p) {
        return rodrigues(Vec3<double>(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)]));
      };
      worst = std::max(worst, norm(matrix_to_axis_angle(transpose(R(a.frames[t])) * R(b.frames[t]))) * 180 / M_PI);
    }
  EXPECT_LT(worst, 0.5);
  // Resampled on request.
  ASSERT_EQ(run_haha("motion --retarget " + quoted(dir / "a.bvh") + " --fps 12 --out " + quoted(dir / "c.npz"), dir, &out), 0) << out;
  EXPECT_EQ(read_motion((dir / "c.npz").string()).frames.size(), 12u);
}

TEST_F(MotionRetargetCli, BadInputIsOneLine) {
  std::string out;
  const fs::path missing = dir / "missing.bvh";
  EXPECT_EQ(run_haha("motion --retarget " + quoted(missing) + " --out " + quoted(dir / "m.npz"), dir, &out), 1);
  EXPECT_EQ(out.rfind("haha: error: " + missing.string() + ": ", 0), 0u) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  EXPECT_EQ(run_haha("motion --in " + quoted(dir / "a.npz") + " --out " + quoted(dir / "a.txt"), dir, &out), 1);
  EXPECT_NE(out.find("give --out M.bvh"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "m.npz"));
}

}  // namespace
}  // namespace haha
