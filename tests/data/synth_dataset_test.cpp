// `haha synth`'s dataset on disk (libhaha/data/synth_dataset.cpp): reads back, deterministic,
// subject 1 byte-exact, atomic replacement, bad options. Runs on the low-resolution
// procedural body at small sizes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "body/lbs.h"
#include "core/error.h"
#include "core/parallel.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "synth/synth_internal.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

using test::low_body;
using haha::test::expect_error;

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("haha_synth_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

SynthOptions small_options() {
  SynthOptions o;
  o.size = 48;
  o.train_frames = 6;
  o.test_frames = 3;
  o.supersample = 2;
  o.texture_size = 256;
  return o;
}

// FNV-1a over bytes: the byte-exact check of subject 1 (tests/synth/synth_subject_test.cpp hashes its renders the same way).
uint64_t fnv1a(uint64_t h, const void* data, size_t n) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001B3ull;
  return h;
}


std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

class SynthDataset : public TempDir {};

TEST_F(SynthDataset, ReadsBackWithMatchingCountsAndConsistentMasks) {
  SynthOptions o = small_options();
  o.fit_noise = {0.02, 0.02};
  const SynthSummary sum = write_synth_dataset(path("ds"), low_body(), o, true);
  EXPECT_GE(sum.min_pose_gap, kSynthMinPoseGap);
  const Dataset ds = read_dataset(path("ds"));
  ASSERT_EQ(ds.frames.size(), 9u);
  EXPECT_EQ(ds.indices(Split::train).size(), 6u);
  EXPECT_EQ(ds.indices(Split::test).size(), 3u);
  ASSERT_EQ(ds.params_true.size(), 9u);
  EXPECT_TRUE(ds.is_static_camera());
  EXPECT_EQ(ds.premultiplied, 1);  // on black with soft coverage masks, flagged
  EXPECT_EQ(ds.fits, Fits::estimated);  // noisy fits
  EXPECT_EQ(ds.width, 48);
  EXPECT_FLOAT_EQ(ds.frames[0].camera.fx, sum.camera.fx);
  EXPECT_FLOAT_EQ(ds.frames[0].camera.cx, 24.0f);
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    const DatasetFrame& f = ds.frames[i];
    EXPECT_NE(f.params.pose, ds.params_true[i].pose);  // fits carry the noise
    EXPECT_NE(f.params.transl, ds.params_true[i].transl);
    int on = 0;
    for (int p = 0; p < 48 * 48; ++p) {
      const float m = f.mask.data[p];
      on += m > 0;
      if (m == 0) {
        for (int c = 0; c < 3; ++c) ASSERT_EQ(f.image.data[3 * p + c], 0.0f) << "frame " << i << " pixel " << p;
      }
    }
    EXPECT_GT(on, 48 * 48 / 50);
  }
  for (const char* extra : {"contact_sheet.png", "synth_texture.png", "body_model.npz"})
    EXPECT_TRUE(fs::exists(dir_ / "ds" / extra)) << extra;
  const Image sheet = read_image(path("ds/contact_sheet.png"));
  EXPECT_GT(sheet.width, 6 * 48);
  // Nothing left beside the output.
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_EQ(e.path().filename(), "ds");
}

// World position of a camera's centre and its view direction.
Vec3f camera_centre(const Camera& c) { return -1.0f * (transpose(c.R) * c.t); }
Vec3f view_direction(const Camera& c) { return c.R.row(2); }

// --unseen: three more frames after the turn and the test poses, split "unseen", exact fits,
// each from its own camera (below the head looking up, above it looking down, in front at a
// pose with the wrists above the head), the whole person inside the frame; the train and
// test frames are those of the dataset written without them.
TEST_F(SynthDataset, UnseenViewsLookFromBelowAboveAndAtRaisedArms) {
  SynthOptions o = small_options();
  write_synth_dataset(path("plain"), low_body(), o, false);
  o.unseen = true;
  const SynthSummary sum = write_synth_dataset(path("ds"), low_body(), o, false);
  EXPECT_EQ(sum.unseen_frames, kSynthUnseenViews);
  const Dataset ds = read_dataset(path("ds")), plain = read_dataset(path("plain"));
  ASSERT_EQ(ds.frames.size(), 9u + kSynthUnseenViews);
  EXPECT_EQ(ds.indices(Split::train).size(), 6u);
  EXPECT_EQ(ds.indices(Split::test).size(), 3u);
  const std::vector<int> un = ds.indices(Split::unseen);
  ASSERT_EQ(un, (std::vector<int>{9, 10, 11}));
  EXPECT_FALSE(ds.is_static_camera());
  for (size_t i = 0; i < plain.frames.size(); ++i) {
    const DatasetFrame &a = ds.frames[i], &b = plain.frames[i];
    EXPECT_EQ(a.split, b.split) << i;
    EXPECT_EQ(a.camera.fx, b.camera.fx) << i;
    EXPECT_EQ(a.camera.t.z, b.camera.t.z) << i;
    EXPECT_EQ(a.params.pose, b.params.pose) << i;
    EXPECT_EQ(a.image.data, b.image.data) << i;
  }
  const Lbs<float> lbs(low_body());
  std::vector<float> verts(size_t(low_body().num_verts) * 3), joints(size_t(kNumJoints) * 3);
  for (int k = 0; k < kSynthUnseenViews; ++k) {
    const DatasetFrame& f = ds.frames[size_t(un[size_t(k)])];
    SCOPED_TRACE(synth_unseen_view_name(k));
    EXPECT_EQ(f.params.pose, ds.params_true[size_t(un[size_t(k)])].pose);  // exact fits
    EXPECT_EQ(f.params.transl, ds.params_true[size_t(un[size_t(k)])].transl);
    lbs.forward(f.params, verts.data(), joints.data(), nullptr);
    auto joint = [&](int j) { return Vec3f(joints[3 * size_t(j)], joints[3 * size_t(j) + 1], joints[3 * size_t(j) + 2]); };
    const Vec3f head = joint(synth::kHeadJoint), C = camera_centre(f.camera), dir = view_direction(f.camera);
    EXPECT_NEAR(norm(dir), 1.0f, 1e-5f);
    EXPECT_GT(dot(dir, head - C), 0.0f);  // the head is in front of the camera
    if (k == kUnseenBelow) {
      EXPECT_LT(C.y, head.y - 0.5f);  // below the chin, looking up
      EXPECT_GT(dir.y, 0.5f);
    } else if (k == kUnseenAbove) {
      EXPECT_GT(C.y, head.y + 0.5f);  // above the head, looking down
      EXPECT_LT(dir.y, -0.5f);
    } else {
      EXPECT_NEAR(dir.z, -1.0f, 1e-5f);  // from the front, level
      EXPECT_GT(joint(20).y, head.y);     // both wrists above the head
      EXPECT_GT(joint(21).y, head.y);
    }
    // The person fills the frame but touches no border (fill 0.9).
    int on = 0, border = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        const bool m = f.mask.data[size_t(y * 48 + x)] > 0;
        on += m;
        border += m && (x == 0 || y == 0 || x == 47 || y == 47);
      }
    EXPECT_GT(on, 48 * 48 / 50);
    EXPECT_EQ(border, 0);
  }
  // One more row on the contact sheet.
  EXPECT_GT(read_image(path("ds/contact_sheet.png")).height, read_image(path("plain/contact_sheet.png")).height);
}

TEST_F(SynthDataset, DeterministicForASeed) {
  const SynthOptions o = small_options();
  write_synth_dataset(path("a"), low_body(), o, false);
  EXPECT_EQ(read_dataset(path("a"), LoadPixels::headers).fits, Fits::exact);  // no fit noise
  // The second run on one thread (frames rendered one by one instead of one per thread).
  const int threads = num_threads();
  set_num_threads(1);
  write_synth_dataset(path("b"), low_body(), o, false);
  set_num_threads(threads);
  SynthOptions o2 = o;
  o2.seed = 9;
  write_synth_dataset(path("c"), low_body(), o2, false);
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir_ / "a")) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), dir_ / "a");
    if (rel.extension() == ".npz") {
      // Arrays, not bytes: the zip container stores member modification times.
      const Npz x = Npz::read(e.path().string()), y = Npz::read((dir_ / "b" / rel).string());
      ASSERT_EQ(x.keys(), y.keys()) << rel;
      for (const std::string& k : x.keys()) {
        EXPECT_EQ(x.get(k).shape, y.get(k).shape) << rel << " " << k;
        EXPECT_EQ(x.get(k).bytes, y.get(k).bytes) << rel << " " << k;
      }
    } else {
      EXPECT_EQ(slurp(e.path()), slurp(dir_ / "b" / rel)) << rel;
    }
    ++files;
  }
  EXPECT_EQ(files, 9 * 2 + 2 + 1 + 2);  // frames, masks, npz x2, dataset.json, sheet, texture
  EXPECT_FALSE(fs::exists(dir_ / "a" / "body_model.npz"));
  EXPECT_NE(slurp(dir_ / "a/images/000001.png"), slurp(dir_ / "c/images/000001.png"));
}

// --part-masks on the turn: one mask per frame beside masks/, the skirt within the person;
// the images are those of a dataset written without them.
TEST_F(SynthDataset, PartMasksNameTheSkirtInEveryFrame) {
  SynthOptions o = small_options();
  write_synth_dataset(path("parts"), low_body(), o, false, nullptr, true);
  write_synth_dataset(path("plain"), low_body(), o, false);
  const Dataset ds = read_dataset(path("parts"));
  EXPECT_FALSE(fs::exists(dir_ / "plain" / kSynthPartMaskDir));
  int frames_with_skirt = 0;
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    const std::string name = fs::path(ds.frames[i].image_path).filename().string();
    EXPECT_EQ(slurp(dir_ / "parts/images" / name), slurp(dir_ / "plain/images" / name));
    const Image part = read_image((dir_ / "parts" / kSynthPartMaskDir / name).string());
    ASSERT_EQ(part.width, o.size);
    int on = 0;
    for (size_t p = 0; p < size_t(o.size) * o.size; ++p) {
      on += part.data[p * size_t(part.channels)] > 0.5f;
      ASSERT_LE(part.data[p * size_t(part.channels)], ds.frames[i].mask.data[p] + 1.5f / 255) << name;
    }
    frames_with_skirt += on > 0;
  }
  EXPECT_EQ(frames_with_skirt, int(ds.frames.size()));
}

// The whole subject-1 pipeline (motion, fit noise, camera, files): bytes of dataset.json,
// the PNGs and the npz arrays, hashed on the code before subject 2 existed.
TEST_F(SynthDataset, SubjectOneDatasetIsExactlyAsBefore) {
  SynthOptions o = small_options();
  o.fit_noise = {0.05, 0.02};
  write_synth_dataset(path("ds"), low_body(), o, false);
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(dir_ / "ds"))
    if (e.is_regular_file()) files.push_back(fs::relative(e.path(), dir_ / "ds"));
  std::sort(files.begin(), files.end());
  uint64_t h = 0xCBF29CE484222325ull;
  for (const fs::path& rel : files) {
    h = fnv1a(h, rel.string().data(), rel.string().size());
    if (rel.extension() == ".npz") {
      const Npz x = Npz::read((dir_ / "ds" / rel).string());
      for (const std::string& k : x.keys()) h = fnv1a(h, x.get(k).bytes.data(), x.get(k).bytes.size());
    } else {
      std::string b = slurp(dir_ / "ds" / rel);
      // dataset.json's "fits" came later than the hash: the rest is as before.
      const std::string fits = " \"fits\": \"estimated\",\n";
      if (rel == "dataset.json") {
        EXPECT_NE(b.find(fits), std::string::npos);
        if (b.find(fits) != std::string::npos) b.erase(b.find(fits), fits.size());
      }
      h = fnv1a(h, b.data(), b.size());
    }
  }
  EXPECT_EQ(h, 5644435470981913490ull);
}

TEST_F(SynthDataset, ReplacesADatasetButNothingElse) {
  const SynthOptions o = small_options();
  write_synth_dataset(path("ds"), low_body(), o, false);
  SynthOptions o2 = o;
  o2.train_frames = 4;
  write_synth_dataset(path("ds"), low_body(), o2, false);  // a dataset may be replaced
  EXPECT_EQ(read_dataset(path("ds"), LoadPixels::headers).frames.size(), 7u);
  fs::create_directories(dir_ / "other");
  std::ofstream(dir_ / "other" / "keep.txt") << "mine";
  expect_error([&] { write_synth_dataset(path("other"), low_body(), o, false); }, "refusing to replace");
  EXPECT_EQ(slurp(dir_ / "other" / "keep.txt"), "mine");
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string n = e.path().filename().string();
    EXPECT_TRUE(n == "ds" || n == "other") << n;
  }
}

TEST(SynthOptionsTest, BadOptionsAreClearErrors) {
  auto with = [](auto edit) {
    SynthOptions o;
    edit(o);
    return o;
  };
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.size = 0; })); }, "--size");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.train_frames = 0; })); }, "--frames");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.test_frames = -1; })); }, "--test-frames");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.fit_noise.pose = -0.1; })); }, "--fit-noise-pose");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.fit_noise.transl = NAN; })); }, "--fit-noise-transl");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.supersample = 0; })); }, "--supersample");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.texture_size = 3; })); }, "--texture-size");
  expect_error([&] { validate_synth_options(with([](SynthOptions& o) { o.size = 4096, o.supersample = 4; })); },
               "exceeds 12288");
  EXPECT_NO_THROW(validate_synth_options(SynthOptions{}));
  expect_error([] { synth_body("/nonexistent/dir/model.npz", BodyResolution::low, 0); }, "/nonexistent/dir/model.npz");
  // write_synth_dataset validates before touching the disk.
  const std::string out = (fs::temp_directory_path() / ("haha_synth_bad_" + std::to_string(::getpid()))).string();
  expect_error([&] { write_synth_dataset(out, low_body(), with([](SynthOptions& o) { o.size = 0; }), false); }, "--size");
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace haha
