// `haha synth --motion` (app/synth_run.cpp): the dataset's frames are the motion file's poses,
// thinned as `haha render` thins; rendering is deterministic; the part masks name the skirt;
// a bad motion file is one line naming it and leaves nothing behind. 64 px, low-resolution
// body, a few frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "app/motion_run.h"
#include "app/synth_run.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "io/image.h"
#include "io/motion.h"
#include "io/npy.h"
#include "support/expect_error.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

class SynthMotionRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("haha_synth_motion_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A walk of `frames` frames as `haha motion` writes it.
  std::string walk(int frames) {
    MotionRunOptions m;
    m.out = path("walk.npz");
    m.kind = "walk";
    m.frames = frames;
    run_motion(m);
    return m.out;
  }
  static SynthRunOptions options(const std::string& motion, const std::string& out) {
    SynthRunOptions o;
    o.out = out;
    o.motion = motion;
    o.resolution = "low";
    o.synth.size = 64;
    o.synth.supersample = 2;
    o.synth.texture_size = 64;
    return o;
  }
  fs::path dir_;
};

std::string bytes(const std::string& file) {
  std::ifstream f(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

TEST_F(SynthMotionRun, FramesAreTheMotionsPosesWithPartMasks) {
  const std::string motion = walk(3);
  SynthRunOptions o = options(motion, path("ds"));
  o.part_masks = true;
  run_synth(o);
  const Dataset ds = read_dataset(path("ds"));
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_TRUE(ds.indices(Split::train).empty());
  EXPECT_EQ(ds.indices(Split::test).size(), 3u);
  EXPECT_EQ(ds.fits, Fits::exact);
  EXPECT_DOUBLE_EQ(ds.fps, 24.0);  // the motion's rate (haha motion's default)
  const Motion m = read_motion(motion);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(ds.frames[i].params.pose, m.frames[i].pose) << "frame " << i;
    EXPECT_EQ(ds.frames[i].params.transl[0], 0.0f);
    EXPECT_EQ(ds.frames[i].params.transl[2], 0.0f);
  }
  // Part masks beside the masks, one per frame: the skirt is seen in every frame of a walk,
  // never outside the person.
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", i);
    const Image part = read_image(path("ds") + "/" + kSynthPartMaskDir + "/" + name);
    const Image& mask = ds.frames[size_t(i)].mask;
    ASSERT_EQ(part.width, 64);
    int on = 0;
    for (size_t p = 0; p < part.data.size(); ++p) {
      on += part.data[p * size_t(part.channels)] > 0.5f;
      ASSERT_LE(part.data[p * size_t(part.channels)], mask.data[p] + 1.5f / 255) << "frame " << i;
    }
    EXPECT_GT(on, 10) << "frame " << i;
  }
}

TEST_F(SynthMotionRun, ThinnedAsRenderThinsAndDeterministic) {
  const std::string motion = walk(5);
  SynthRunOptions o = options(motion, path("a"));
  o.every = 2;
  o.max_frames = 2;
  run_synth(o);
  o.out = path("b");
  run_synth(o);
  const Dataset ds = read_dataset(path("a"));
  ASSERT_EQ(ds.frames.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.fps, 12.0);  // every other frame of 24 fps
  const Motion m = read_motion(motion);
  EXPECT_EQ(ds.frames[1].params.pose, m.frames[2].pose);
  EXPECT_FALSE(fs::exists(path("a") + "/" + kSynthPartMaskDir));  // only with --part-masks
  for (const char* f : {"images/000000.png", "images/000001.png", "masks/000001.png", "smplx/params.npz"})
    EXPECT_EQ(bytes(path("a") + "/" + f), bytes(path("b") + "/" + f)) << f;
}

TEST_F(SynthMotionRun, AnAmassFileIsTurnedUpright) {
  // SMPL+H layout, Z-up: a standing person (the rest pose's +Y turned to +Z, 90 degrees
  // about X) walking 1 m along +X between the two frames.
  std::vector<double> poses(2 * 156, 0.0);
  poses[0] = poses[156] = M_PI / 2;
  Npz z;
  z.set("poses", NpyArray::from(poses, {2, 156}));
  z.set("trans", NpyArray::from(std::vector<double>{0, 0, 0.9, 1, 0, 0.9}, {2, 3}));
  z.set("mocap_framerate", NpyArray::from(std::vector<double>{60}, {}));
  z.write(path("amass.npz"));
  run_synth(options(path("amass.npz"), path("ds")));
  const Dataset ds = read_dataset(path("ds"));
  ASSERT_EQ(ds.frames.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.fps, 60.0);
  for (const DatasetFrame& f : ds.frames) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.params.pose[size_t(c)], 0.0, 1e-5);  // upright in haha's Y-up world
    EXPECT_EQ(f.params.transl[0], 0.0f);  // the walk's travel is dropped
    EXPECT_EQ(f.params.transl[2], 0.0f);
  }
  // Both frames are the same pose held in place: the same image.
  EXPECT_EQ(bytes(path("ds") + "/images/000000.png"), bytes(path("ds") + "/images/000001.png"));
}

TEST_F(SynthMotionRun, ABadMotionFileIsOneLineNamingItAndWritesNothing) {
  const std::string bad = path("bad.npz");
  std::ofstream(bad) << "not a motion";
  test::expect_error_at(bad, [&] { run_synth(options(bad, path("out"))); }, {});
  test::expect_error_at(path("missing.npz"), [&] { run_synth(options(path("missing.npz"), path("out"))); }, {});
  EXPECT_FALSE(fs::exists(path("out")));
  SynthRunOptions o = options(walk(2), path("out"));
  o.every = 0;
  test::expect_error_at("--every", [&] { run_synth(o); }, {"positive"});
  EXPECT_FALSE(fs::exists(path("out")));
}

}  // namespace
}  // namespace haha
