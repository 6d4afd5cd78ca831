// Coarse to fine (train/levels.h): the step schedule over pyramid levels, the frames and
// texture resampled between levels, and the trainer across its levels: images and texture
// of the right size at each level, a resumed run that repeats the uninterrupted one
// bit for bit across level changes, and clear errors for schedules the data cannot hold.
#include <gtest/gtest.h>

#include <cmath>

#include "body/rotation.h"
#include "core/error.h"
#include "support/expect_error.h"
#include "support/train_test_scene.h"
#include "train/config.h"
#include "train/levels.h"
#include "train/trainer.h"

namespace haha {
namespace {

using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

TEST(LevelSchedule, SharesSplitTheStepsCoarsestFirst) {
  const LevelSchedule s = make_level_schedule("6,3,1", 100, "s1.levels");
  ASSERT_EQ(s.num_levels(), 3);
  EXPECT_EQ(s.ends, (std::vector<int>{60, 90, 100}));
  EXPECT_EQ(s.level_of(0), 0);
  EXPECT_EQ(s.level_of(59), 0);
  EXPECT_EQ(s.level_of(60), 1);
  EXPECT_EQ(s.level_of(99), 2);
  EXPECT_EQ(s.level_of(100), 2);  // past the end: the last level
  // Any positive scale; a zero share is a level with no steps; no text: one level.
  EXPECT_EQ(make_level_schedule("0.5,0.5", 7, "k").ends, (std::vector<int>{4, 7}));
  const LevelSchedule z = make_level_schedule("0,1", 10, "k");
  EXPECT_EQ(z.level_of(0), 1);
  EXPECT_EQ(make_level_schedule("", 10, "k").num_levels(), 1);
  EXPECT_EQ(make_level_schedule("", 10, "k").level_of(5), 0);
}

TEST(LevelSchedule, BadTextIsAnErrorNamingTheKey) {
  for (const char* bad : {"a,b", "1,,2", "-1,2", "0,0", "1,1,1,1,1,1,1", "1;2"})
    test::expect_error([&] { make_level_schedule(bad, 10, "s2.levels"); }, {"s2.levels"});
  TrainConfig c = make_preset("tiny");
  c.s3.levels = "2,x";
  test::expect_error([&] { validate_config(c); }, {"s3.levels"});
}

TEST(LevelSchedule, SidesHalvePerCoarserLevel) {
  EXPECT_EQ(level_side(512, 0, 3), 128);
  EXPECT_EQ(level_side(512, 1, 3), 256);
  EXPECT_EQ(level_side(512, 2, 3), 512);
  EXPECT_EQ(level_side(300, 0, 2), 150);
  EXPECT_EQ(level_side(5, 0, 4), 1);  // rounded, at least 1
}

TEST(Levels, DownscaledFrameKeepsProjectionAndMass) {
  TrainFrame f = scene_frames(scene_truth(), 1, 64)[0];
  const TrainFrame h = downscale_train_frame(f, 32);
  ASSERT_EQ(h.camera.width, 32);
  ASSERT_EQ(h.camera.height, 32);
  ASSERT_EQ(h.rgb.size(), size_t(32 * 32 * 3));
  ASSERT_EQ(h.mask.size(), size_t(32 * 32));
  // Pixel-edge convention: a point at u px in the full frame is at u / 2 in the half one.
  const Vec3f x(0.1f, 0.2f, 0.3f);
  auto project = [&](const Camera& c) {
    const Vec3f p = c.R * x + c.t;
    return std::array<double, 2>{c.fx * p[0] / p[2] + c.cx, c.fy * p[1] / p[2] + c.cy};
  };
  const auto a = project(f.camera), b = project(h.camera);
  EXPECT_NEAR(b[0], a[0] / 2, 1e-4);
  EXPECT_NEAR(b[1], a[1] / 2, 1e-4);
  // The area filter keeps the mean of every image.
  double ma = 0, mb = 0, ra = 0, rb = 0;
  for (float v : f.mask) ma += v / f.mask.size();
  for (float v : h.mask) mb += v / h.mask.size();
  for (float v : f.rgb) ra += v / f.rgb.size();
  for (float v : h.rgb) rb += v / h.rgb.size();
  EXPECT_NEAR(ma, mb, 1e-5);
  EXPECT_NEAR(ra, rb, 1e-5);
  // The same size: as given.
  EXPECT_EQ(downscale_train_frame(f, 64).rgb, f.rgb);
  // A mask of ones at an uneven ratio (970 x 720 -> 128, as a cropped video): averages of
  // ones round to just above 1 in float; the mask stays in [0, 1].
  TrainFrame wide;
  wide.camera = f.camera;
  wide.camera.width = 970;
  wide.camera.height = 720;
  wide.rgb.assign(size_t(970) * 720 * 3, 0.5f);
  wide.mask.assign(size_t(970) * 720, 1.0f);
  for (int side : {128, 333, 512}) {
    const TrainFrame w = downscale_train_frame(wide, side);
    for (float m : w.mask) ASSERT_TRUE(m >= 0.0f && m <= 1.0f) << side << " " << m;
  }
}

TEST(Levels, ResampledTextureShowsWhatTheCoarseOneShowed) {
  // A texture linear in (u, v): bilinear sampling reproduces it between the outer texel
  // centres, so the upsampled texture holds the same function there.
  const int S = 8, N = 16;
  std::vector<float> t(size_t(S) * S * 3);
  auto f = [](double u, double v, int c) { return 0.1 + 0.5 * u + 0.3 * v + 0.05 * c; };
  for (int j = 0; j < S; ++j)
    for (int i = 0; i < S; ++i)
      for (int c = 0; c < 3; ++c)
        t[(size_t(j) * S + i) * 3 + c] = float(f((i + 0.5) / S, 1 - (j + 0.5) / S, c));
  const std::vector<float> up = resample_texture(t, S, N);
  ASSERT_EQ(up.size(), size_t(N) * N * 3);
  for (int j = 1; j < N - 1; ++j)
    for (int i = 1; i < N - 1; ++i)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(up[(size_t(j) * N + i) * 3 + c], f((i + 0.5) / N, 1 - (j + 0.5) / N, c), 1e-6) << i << "," << j;
  EXPECT_EQ(resample_texture(t, S, S), t);
}

// The scene at 64 px with every stage coarse to fine over two levels (32 and 64 px).
TrainConfig level_config() {
  TrainConfig c = scene_config(10, 8, 8);
  c.s1.levels = "1,1";
  c.s2.levels = "1,1";
  c.s3.levels = "1,1";
  c.s2.texture_size = 32;
  return c;
}

const std::vector<TrainFrame>& frames64() {
  static const std::vector<TrainFrame> f = scene_frames(scene_truth(), 6, 64);
  return f;
}

TEST(TrainerLevels, ImagesAndTextureGrowLevelByLevel) {
  Trainer t(level_config(), scene_input(frames64()));
  std::vector<std::string> events;
  std::vector<int> texture_sizes;
  while (!t.done()) {
    const StepReport r = t.step();
    if (!r.event.empty()) events.push_back(r.event);
    texture_sizes.push_back(t.save().i32.at("meta.texture_size")[0]);
  }
  auto has = [&](const std::string& needle) {
    for (const std::string& e : events)
      if (e.find(needle) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has("level 2/2: 64x64 px")) << "stage 1 and 3 move to the full size";
  EXPECT_TRUE(has("begin stage 2 (level 1/2: 32x32 px, texture 16^2)"));
  EXPECT_TRUE(has("level 2/2: 64x64 px, texture 32^2"));
  EXPECT_TRUE(has("begin stage 3 (level 1/2: 32x32 px)"));
  // Stage 2's texture: 16^2 for its first 4 steps, then 32^2; the avatar has the full size.
  EXPECT_EQ(texture_sizes[10], 16);  // after stage 2's first step
  EXPECT_EQ(texture_sizes[13], 16);
  EXPECT_EQ(texture_sizes[14], 32);
  EXPECT_EQ(t.avatar().texture.width, 32);
}

TEST(TrainerLevels, ResumeAcrossLevelsRepeatsTheUninterruptedRun) {
  const TrainConfig c = level_config();
  Trainer ref(c, scene_input(frames64()));
  std::vector<TrainCheckpoint> snaps;
  while (!ref.done()) {
    ref.step();
    snaps.push_back(ref.save());
  }
  const TrainCheckpoint want = ref.save();
  // Just before and after each level change (steps 5 of stage 1, 4 of stage 2, 4 of
  // stage 3), and with stage 2's texture still at the coarse size.
  for (int k : {4, 5, 6, 12, 14, 15, 21, 22}) {
    Trainer t(c, scene_input(frames64()));
    t.load(snaps[size_t(k - 1)], "snapshot");
    while (!t.done()) t.step();
    const TrainCheckpoint got = t.save();
    for (const auto& [key, v] : want.f32) {
      ASSERT_TRUE(got.f32.count(key)) << key;
      EXPECT_EQ(got.f32.at(key), v) << "k=" << k << " " << key;
    }
  }
}

TEST(TrainerLevels, StageTwoWithoutStepsStillLeavesTheFullTexture) {
  TrainConfig c = level_config();
  c.s2.steps = 0;
  Trainer t(c, scene_input(frames64()));
  while (!t.done()) t.step();
  EXPECT_EQ(t.avatar().texture.width, 32);
}

TEST(TrainerLevels, TooManyLevelsForTheImagesIsAnError) {
  TrainConfig c = level_config();
  c.s1.levels = "1,1,1,1,1";  // 64 px / 16 = 4 px
  test::expect_error([&] { Trainer t(c, scene_input(frames64())); }, {"s1.levels", "too small"});
  c = level_config();
  c.s2.texture_size = 8;
  c.s2.levels = "1,1,1";  // 2 texels
  test::expect_error([&] { Trainer t(c, scene_input(frames64())); }, {"s2.levels", "texels"});
}

TEST(TrainerLevels, CheckpointTextureSizeMustBeOneOfTheLevels) {
  const TrainConfig c = level_config();
  Trainer t(c, scene_input(frames64()));
  for (int i = 0; i < 12; ++i) t.step();  // into stage 2, texture 16^2
  TrainCheckpoint ck = t.save();
  ck.i32["meta.texture_size"] = {24};
  Trainer u(c, scene_input(frames64()));
  test::expect_error([&] { u.load(ck, "ck.npz"); }, {"ck.npz", "meta.texture_size"});
}

double max_pose_change(const Trainer& t, const std::vector<TrainFrame>& f) {
  double m = 0;
  const std::vector<SmplxParams> p = t.refined_params();
  for (size_t i = 0; i < f.size(); ++i)
    for (size_t k = 0; k < p[i].pose.size(); ++k) m = std::max(m, double(std::abs(p[i].pose[k] - f[i].params.pose[k])));
  return m;
}

TEST(TrainerLevels, PoseRatesScaleWithTheLevelAndBetasCanStayAsFitted) {
  // s1.lr.pose_level_exp: at the coarse level (half the side) the pose rates are 2^-40 of
  // theirs, so the poses stay put there and move at the full-size level.
  TrainConfig c = level_config();
  c.s1.lr_pose_level_exp = 40;
  c.s1.lr_betas_scale = 0;
  Trainer t(c, scene_input(frames64()));
  for (int i = 0; i < 5; ++i) t.step();  // stage 1's coarse level
  EXPECT_LT(max_pose_change(t, frames64()), 1e-9);
  for (int i = 0; i < 5; ++i) t.step();
  EXPECT_GT(max_pose_change(t, frames64()), 1e-5);
  // Betas as fitted (the frames' mean) after the pose moved.
  for (size_t k = 0; k < t.refined_params()[0].betas.size(); ++k)
    EXPECT_EQ(t.refined_params()[0].betas[k], frames64()[0].params.betas[k]);
}

TEST(TrainConfig, StandardPresetAndTheResolutionCap) {
  const TrainConfig s = make_preset("standard");
  validate_config(s);
  EXPECT_EQ(train_resolution(s, 1080), 512);
  EXPECT_EQ(train_resolution(s, 300), 300);  // never upsampled
  const TrainConfig t = make_preset("tiny");
  EXPECT_EQ(train_resolution(t, 1080), 128);
  TrainConfig p = make_preset("paper");
  p.resolution = 0;
  EXPECT_EQ(train_resolution(p, 1080), 1080);
  test::expect_error([] { make_preset("fast"); }, {"--preset", "tiny, standard, paper"});
}

}  // namespace
}  // namespace haha
