// The garment decision (train/garment_fit.h) on frames of the procedural body with its legs
// apart: masks of the bare body (trousers) make no garment; masks whose rows between the
// crotch and the knees are filled from leg to leg (a skirt to the knee) make one whose hem
// is near the knee; a filled band narrowing down to the knees (loose trousers' crotch) is
// not a hem; `none` and `skirt` force the answer; a frame without a mask is named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "body/lbs.h"
#include "core/error.h"
#include "support/train_test_scene.h"
#include "train/garment_fit.h"
#include "train/silhouette_fit.h"

namespace haha {
namespace {

using test::scene_body;

constexpr int kSize = 96;

enum class Fill { bare, skirt, crotch };

// Frames seen from the front and slightly turned, the legs spread; `skirt` fills each row of
// the mask between the pelvis joint and the knees from its leftmost to its rightmost pixel,
// `crotch` fills a band about the middle that narrows to nothing at the knees (loose
// trousers' inverted V).
std::vector<TrainFrame> frames(Fill fill) {
  const BodyModel& b = scene_body();
  Lbs<float> lbs(b);
  BodySilhouette sil(b);
  std::vector<TrainFrame> out;
  for (int i = 0; i < 5; ++i) {
    TrainFrame f;
    f.name = "frame" + std::to_string(i) + ".png";
    f.camera = test::scene_camera(kSize);
    f.params.pose[1] = 0.15f * float(i - 2);  // turn a little about the vertical axis
    f.params.pose[3 * 1 + 2] = 0.25f;          // left hip out
    f.params.pose[3 * 2 + 2] = -0.25f;         // right hip out
    std::vector<float> v(3 * size_t(b.num_verts)), j(3 * size_t(kNumJoints));
    lbs.forward(f.params, v.data(), j.data(), nullptr);
    const std::vector<float>& cov = sil.render(f.camera, v.data());
    const int P = kSize * kSize;
    f.mask.resize(size_t(P));
    for (int p = 0; p < P; ++p) f.mask[size_t(p)] = cov[3 * size_t(p)] >= 0.5f ? 1.0f : 0.0f;
    f.rgb.assign(3 * size_t(P), 0.5f);
    if (fill != Fill::bare) {
      auto row = [&](int joint) {
        return f.camera.project(f.camera.to_camera({j[3 * size_t(joint)], j[3 * size_t(joint) + 1], j[3 * size_t(joint) + 2]})).y;
      };
      const int y0 = int(row(0)), y1 = int(0.5f * (row(4) + row(5)));
      for (int y = std::max(0, y0); y <= std::min(kSize - 1, y1); ++y) {
        int lo = kSize, hi = -1;
        for (int x = 0; x < kSize; ++x)
          if (f.mask[size_t(y) * kSize + x] > 0) lo = std::min(lo, x), hi = std::max(hi, x);
        if (fill == Fill::skirt) {
          for (int x = lo; x <= hi; ++x) f.mask[size_t(y) * kSize + x] = 1;
          continue;
        }
        // The gap between the legs about the row's middle, filled at its centre by a band
        // narrowing from the whole gap a third of the way down to nothing at the knees.
        const int mid = (lo + hi) / 2;
        if (lo > hi || f.mask[size_t(y) * kSize + mid] > 0) continue;
        int gl = mid, gr = mid;
        while (gl > lo && f.mask[size_t(y) * kSize + gl - 1] == 0) --gl;
        while (gr < hi && f.mask[size_t(y) * kSize + gr + 1] == 0) ++gr;
        const double ym = y0 + (y1 - y0) / 3.0, centre = 0.5 * (gl + gr);
        const double narrow = std::clamp((y - ym) / std::max(1.0, y1 - ym), 0.0, 1.0);
        for (int x = gl; x <= gr; ++x)
          if (std::abs(x - centre) <= (0.5 * (gr - gl) + 0.5) * (1 - narrow)) f.mask[size_t(y) * kSize + x] = 1;
      }
    }
    out.push_back(std::move(f));
  }
  return out;
}

double hem_t(const GarmentDecision& d) {
  // y_hem back to t down the leg: 0 at the hip joints, 1 at the ankles (rest, zero betas).
  std::vector<float> v(3 * size_t(scene_body().num_verts)), j(3 * size_t(kNumJoints));
  Lbs<float>(scene_body()).forward(SmplxParams{}, v.data(), j.data(), nullptr);
  const double hip = 0.5 * (j[4] + j[7]), ankle = 0.5 * (j[22] + j[25]);
  return (d.y_hem - hip) / (ankle - hip);
}

TEST(GarmentFit, BareLegsMakeNoGarment) {
  Stage0Config::Garment opt;
  const GarmentDecision d = decide_garment(scene_body(), frames(Fill::bare), opt);
  EXPECT_FALSE(d.made) << d.why;
  EXPECT_NE(d.why.find("the space between the legs is background"), std::string::npos) << d.why;
  EXPECT_TRUE(d.garment.empty());
  long seen = 0;
  for (size_t k = 0; k < d.fill.size(); ++k) {
    seen += d.pixels[k];
    if (!std::isnan(d.fill[k])) {
      EXPECT_LT(d.fill[k], 0.2) << "level " << k;
    }
  }
  EXPECT_GT(seen, 100) << "the legs must be apart in these frames";
}

TEST(GarmentFit, AFilledGapMakesASkirtToTheKnee) {
  Stage0Config::Garment opt;
  const GarmentDecision d = decide_garment(scene_body(), frames(Fill::skirt), opt);
  ASSERT_TRUE(d.made) << d.why;
  EXPECT_GT(d.fill[0], 0.8);
  EXPECT_GT(d.y_top, d.y_hem);
  const double t = hem_t(d);
  EXPECT_GT(t, 0.35) << d.why;
  EXPECT_LT(t, 0.65) << d.why;
  EXPECT_EQ(d.garment.num_verts(), opt.rings * opt.columns);
  validate_garment(d.garment, "test");
}

TEST(GarmentFit, ACrotchThatFadesIsNotAHem) {
  Stage0Config::Garment opt;
  const GarmentDecision d = decide_garment(scene_body(), frames(Fill::crotch), opt);
  EXPECT_GT(d.fill[0], 0.8) << "the top is filled as under a skirt";
  EXPECT_FALSE(d.made) << d.why;
  EXPECT_NE(d.why.find("a crotch, not a hem"), std::string::npos) << d.why;
  const GarmentDecision skirt = decide_garment(scene_body(), frames(Fill::skirt), opt);
  ASSERT_TRUE(skirt.made) << skirt.why;
  // The edges each states: the crotch's wider than allowed, the skirt's hem within it.
  double crotch_edge = 0, hem_edge = 0;
  ASSERT_EQ(std::sscanf(d.why.c_str(), "no garment: the fill between the legs fades over %lf", &crotch_edge), 1) << d.why;
  const size_t at = skirt.why.find("its edge ");
  ASSERT_NE(at, std::string::npos) << skirt.why;
  ASSERT_EQ(std::sscanf(skirt.why.c_str() + at, "its edge %lf", &hem_edge), 1) << skirt.why;
  EXPECT_GT(crotch_edge, opt.max_edge);
  EXPECT_LE(hem_edge, opt.max_edge);
}

TEST(GarmentFit, ModesForceTheAnswerAndBadFramesAreNamed) {
  Stage0Config::Garment opt;
  opt.mode = "none";
  EXPECT_FALSE(decide_garment(scene_body(), frames(Fill::skirt), opt).made);
  opt.mode = "skirt";
  const GarmentDecision forced = decide_garment(scene_body(), frames(Fill::bare), opt);
  EXPECT_TRUE(forced.made);
  EXPECT_NE(forced.why.find("forced"), std::string::npos) << forced.why;
  opt.mode = "trousers";
  EXPECT_THROW(decide_garment(scene_body(), frames(Fill::bare), opt), Error);
  opt.mode = "auto";
  std::vector<TrainFrame> bad = frames(Fill::bare);
  bad[0].mask.clear();
  try {
    decide_garment(scene_body(), bad, opt);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame0.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace haha
