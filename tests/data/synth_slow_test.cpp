// The synthetic subject at full scale: the default `haha synth` run on the full
// procedural body, garments clear of the full body, a 1024 px frame, and novel test
// poses over long sequences.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "body/procedural_body.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "synth/synth_internal.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

const BodyModel& full_body() {
  static const BodyModel b = make_procedural_body({});
  return b;
}

fs::path temp(const std::string& name) {
  return fs::temp_directory_path() / ("haha_synth_slow_" + std::to_string(::getpid()) + "_" + name);
}

void expect_consistent(const Dataset& ds) {
  for (const DatasetFrame& f : ds.frames) {
    int on = 0;
    const int P = ds.width * ds.height;
    for (int p = 0; p < P; ++p) {
      on += f.mask.data[p] > 0;
      if (f.mask.data[p] == 0) {
        for (int c = 0; c < 3; ++c) ASSERT_EQ(f.image.data[3 * p + c], 0.0f);
      }
    }
    EXPECT_GT(on, P / 50);
    for (int k = 0; k < ds.width; ++k) {  // full body in frame
      EXPECT_EQ(f.mask.data[k], 0.0f);
      EXPECT_EQ(f.mask.data[size_t(ds.height - 1) * ds.width + k], 0.0f);
    }
  }
}

TEST(SynthSlow, SubjectTwoOnTheFullBody) {
  const fs::path out = temp("subject2");
  SynthOptions o;
  o.subject = 2;
  o.train_frames = 12;
  o.test_frames = 6;
  const SynthSummary s = write_synth_dataset(out.string(), full_body(), o, false);
  EXPECT_GE(s.min_pose_gap, kSynthMinPoseGap);
  const Dataset ds = read_dataset(out.string());
  EXPECT_EQ(ds.frames.size(), 18u);
  expect_consistent(ds);  // masks agree with the images, the whole person in frame
  EXPECT_NE(ds.source.find("subject 2"), std::string::npos) << ds.source;
  ASSERT_EQ(ds.params_true.size(), 18u);
  EXPECT_GT(ds.params_true[0].betas[0], 1.0f);  // the taller shape travels with the fits
  fs::remove_all(out);
}

TEST(SynthSlow, DefaultRunOnTheFullBody) {
  const fs::path out = temp("default");
  const SynthSummary s = write_synth_dataset(out.string(), full_body(), SynthOptions{}, true);
  EXPECT_GE(s.min_pose_gap, kSynthMinPoseGap);
  const Dataset ds = read_dataset(out.string());
  EXPECT_EQ(ds.frames.size(), 50u);
  EXPECT_EQ(ds.indices(Split::test).size(), 10u);
  EXPECT_EQ(ds.width, 128);
  expect_consistent(ds);
  EXPECT_TRUE(fs::exists(out / "body_model.npz"));
  fs::remove_all(out);
}

TEST(SynthSlow, GarmentsClearTheFullBodyAtRest) {
  const SynthSubject s = make_synth_subject(full_body(), {});
  ProceduralBodyInfo info;
  make_procedural_body({}, &info);
  const BodyModel& b = full_body();
  auto P = [&](const std::vector<float>& v, int i) { return synth::V3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); };
  const synth::V3 dir = synth::unit(synth::V3(1, 0.31, 0.17));
  auto crosses = [&](synth::V3 o, int f) {
    const synth::V3 a = P(s.rest_verts, b.faces[3 * f]), e1 = P(s.rest_verts, b.faces[3 * f + 1]) - a,
                    e2 = P(s.rest_verts, b.faces[3 * f + 2]) - a;
    const synth::V3 p = cross(dir, e2);
    const double det = dot(e1, p);
    if (std::abs(det) < 1e-18) return false;
    const synth::V3 t = o - a, q = cross(t, e1);
    const double u = dot(t, p) / det, v = dot(dir, q) / det;
    return u >= 0 && v >= 0 && u + v <= 1 && dot(e2, q) / det > 0;
  };
  for (const SynthMesh& m : s.meshes) {
    if (m.name == "ponytail") continue;  // its root is meant to sit in the hair
    int inside = 0;
    for (int v = 0; v < m.num_verts(); ++v)
      for (const ProceduralPart& part : info.parts) {
        int n = 0;
        for (int f = part.first_face; f < part.first_face + part.num_faces; ++f) n += crosses(P(m.rest, v), f);
        if (n % 2) {
          ++inside;
          break;
        }
      }
    EXPECT_EQ(inside, 0) << m.name;
  }
}

TEST(SynthSlow, Renders1024PixelFrames) {
  const fs::path out = temp("1024");
  SynthOptions o;
  o.size = 1024;
  o.train_frames = 2;
  o.test_frames = 1;
  const SynthSummary s = write_synth_dataset(out.string(), full_body(), o, false);
  EXPECT_EQ(s.texture_size, 2048);
  const Dataset ds = read_dataset(out.string());
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.frames[0].image.width, 1024);
  expect_consistent(ds);
  fs::remove_all(out);
}

TEST(SynthSlow, LongSequencesKeepTestPosesNovel) {
  const SynthSubject s = make_synth_subject(full_body(), {});
  const SynthMotion m = make_synth_motion(full_body(), s, 600, 150, 11);
  double gap = 1e9;
  for (const SmplxParams& t : m.test)
    for (const SmplxParams& r : m.train) gap = std::min(gap, pose_distance(t, r));
  EXPECT_GE(gap, kSynthMinPoseGap);
}

}  // namespace
}  // namespace haha
