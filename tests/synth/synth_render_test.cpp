// Renders of the synthetic subject (libhaha/synth/synth_render.cpp): soft masks consistent
// with the images, Y up on screen, garments outside the body silhouette. Low-resolution
// procedural body at small sizes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/error.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/synth_mesh_checks.h"
#include "support/synth_low_subject.h"
#include "synth/synth_internal.h"

namespace haha {
namespace {

using test::low_body;

using test::low_subject;

// ---------------------------------------------------------------------------------------
// Rendering

struct Scene {
  SynthMotion motion = make_synth_motion(low_body(), low_subject(), 8, 4, 0);
  SynthRenderer renderer{low_body(), low_subject()};
  Camera cam;
  explicit Scene(int size = 64) {
    std::vector<const SmplxParams*> all;
    for (const auto& p : motion.train) all.push_back(&p);
    for (const auto& p : motion.test) all.push_back(&p);
    cam = synth_camera(renderer, all, size);
  }
};

int count(const Image& m, float thr = 0.0f) {
  int n = 0;
  for (float x : m.data) n += x > thr;
  return n;
}

TEST(SynthRender, MasksAreSoftNonEmptyAndConsistentWithTheImages) {
  Scene sc;
  Image rgb, mask;
  bool soft = false;
  std::vector<SmplxParams> all = sc.motion.train;
  all.insert(all.end(), sc.motion.test.begin(), sc.motion.test.end());
  for (const SmplxParams& p : all) {
    sc.renderer.render(sc.cam, p, 3, kSynthAll, rgb, mask);
    ASSERT_EQ(rgb.width, 64);
    ASSERT_EQ(mask.channels, 1);
    EXPECT_GT(count(mask), 64 * 64 / 50);
    for (int i = 0; i < 64 * 64; ++i) {
      const float m = mask.data[i];
      ASSERT_TRUE(m >= 0 && m <= 1);
      soft |= (m > 0 && m < 1);
      for (int c = 0; c < 3; ++c) {
        const float v = rgb.data[3 * i + c];
        ASSERT_TRUE(std::isfinite(v) && v >= 0 && v <= m + 1e-6f) << i;  // colour <= coverage: black outside
      }
    }
    // Full body in frame: nothing touches the border.
    for (int k = 0; k < 64; ++k) {
      EXPECT_EQ(mask.at(k, 0, 0), 0.0f);
      EXPECT_EQ(mask.at(k, 63, 0), 0.0f);
      EXPECT_EQ(mask.at(0, k, 0), 0.0f);
      EXPECT_EQ(mask.at(63, k, 0), 0.0f);
    }
  }
  EXPECT_TRUE(soft) << "supersampled coverage should give fractional edge pixels";
}

TEST(SynthRender, BodyYUpAppearsUpright) {
  Scene sc;
  Lbs<float> lbs(low_body());
  std::vector<float> v(size_t(low_body().num_verts) * 3), J(kNumJoints * 3);
  for (const SmplxParams& p : sc.motion.train) {
    lbs.forward(p, v.data(), J.data(), nullptr);
    auto row = [&](int j) { return sc.cam.project(sc.cam.to_camera(Vec3f(J[3 * j], J[3 * j + 1], J[3 * j + 2]))).y; };
    EXPECT_LT(row(15), row(0));  // head above pelvis
    EXPECT_LT(row(0), row(7));   // pelvis above the ankle
  }
  // Frame 0 faces the camera: the subject's left hand (+X) is on the image's right.
  lbs.forward(sc.motion.train[0], v.data(), J.data(), nullptr);
  auto col = [&](int j) { return sc.cam.project(sc.cam.to_camera(Vec3f(J[3 * j], J[3 * j + 1], J[3 * j + 2]))).x; };
  EXPECT_GT(col(20), col(21));
}

TEST(SynthRender, GarmentsCoverPixelsOutsideTheBodySilhouette) {
  Scene sc(128);
  Image rgb, body_mask, mask;
  // Frame 0 faces the camera; the ponytail shows from the side (a quarter turn).
  const SmplxParams& front = sc.motion.train[0];
  const SmplxParams& side = sc.motion.train[2];
  sc.renderer.render(sc.cam, front, 3, kSynthBody, rgb, body_mask);
  const int body_px = count(body_mask);
  // Pixels with coverage where the body alone has none (3 x 3 subsamples per pixel).
  auto extra = [&](const SmplxParams& p, unsigned parts) {
    Image bm;
    sc.renderer.render(sc.cam, p, 3, kSynthBody, rgb, bm);
    sc.renderer.render(sc.cam, p, 3, kSynthBody | parts, rgb, mask);
    int more = 0;
    for (size_t i = 0; i < mask.data.size(); ++i) {
      EXPECT_GE(mask.data[i], bm.data[i]);  // adding geometry never removes coverage
      more += mask.data[i] > 0 && bm.data[i] == 0;
    }
    return more;
  };
  const int all = extra(front, kSynthAll);
  EXPECT_GT(all, body_px / 20) << "clothed silhouette should be clearly larger than the body's";
  EXPECT_GT(extra(front, kSynthSkirt), body_px / 40);
  EXPECT_GT(extra(front, kSynthHair), 0);
  EXPECT_GT(extra(side, kSynthPonytail), 0);
  EXPECT_GT(extra(side, kSynthHair), 0);
}

}  // namespace
}  // namespace haha
