// A motion placed on the synthetic subject (libhaha/synth/synth_motion_place.cpp) and the
// garment's part mask of the renderer (synth_render.cpp): poses kept, travel dropped, feet
// on the floor; the part mask covers the skirt and nothing when there is no garment.
// Low-resolution procedural body at 64 px.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "body/lbs.h"
#include "core/error.h"
#include "support/low_body.h"
#include "support/synth_low_subject.h"
#include "synth/synth_subject.h"

namespace haha {
namespace {

using test::low_body;
using test::low_subject;

// Three frames that travel forward and sideways and rise, with a bent knee and a turn.
std::vector<SmplxParams> travelling_motion() {
  std::vector<SmplxParams> m(3);
  for (int i = 0; i < 3; ++i) {
    SmplxParams& p = m[size_t(i)];
    p.pose[1] = 0.4f * float(i);             // global orient about Y
    p.pose[3 * 4] = 0.5f + 0.2f * float(i);  // left knee
    p.transl = {1.5f * float(i), 0.9f + 0.05f * float(i), -2.0f * float(i)};
  }
  return m;
}

double lowest_y(const SmplxParams& p) {
  const Lbs<float> lbs(low_body());
  std::vector<float> v(size_t(low_body().num_verts) * 3);
  lbs.forward(p, v.data(), nullptr, nullptr);
  double lo = 1e30;
  for (size_t k = 1; k < v.size(); k += 3) lo = std::min(lo, double(v[k]));
  return lo;
}

TEST(SynthMotionPlace, KeepsThePosesDropsTheTravelAndStandsOnTheFloor) {
  const std::vector<SmplxParams> in = travelling_motion();
  const std::vector<SmplxParams> out = place_synth_motion(low_body(), low_subject(), in);
  ASSERT_EQ(out.size(), in.size());
  double floor_y = 1e30;
  for (size_t k = 1; k < low_subject().rest_verts.size(); k += 3)
    floor_y = std::min(floor_y, double(low_subject().rest_verts[k]));
  double lowest = 1e30;
  for (size_t i = 0; i < out.size(); ++i) {
    for (int k = 0; k < kNumPoseValues; ++k) ASSERT_EQ(out[i].pose[size_t(k)], in[i].pose[size_t(k)]) << i << " " << k;
    EXPECT_EQ(out[i].transl[0], 0.0f);
    EXPECT_EQ(out[i].transl[2], 0.0f);
    EXPECT_EQ(out[i].betas, low_subject().betas);
    lowest = std::min(lowest, lowest_y(out[i]));
  }
  // One shift for all frames: the rise between frames survives.
  EXPECT_NEAR(out[2].transl[1] - out[0].transl[1], in[2].transl[1] - in[0].transl[1], 1e-5);
  EXPECT_NEAR(lowest, floor_y, 1e-4);
}

TEST(SynthMotionPlace, TheSceneIsTheMotionEveryFrameATestFrame) {
  SynthOptions o;
  o.size = 64;
  o.texture_size = 64;
  o.supersample = 1;
  SynthScene sc = make_synth_subject_scene(low_body(), o);
  const std::vector<SmplxParams> in = travelling_motion();
  set_synth_scene_motion(low_body(), sc, in);
  EXPECT_EQ(sc.options.train_frames, 0);
  EXPECT_EQ(sc.options.test_frames, 3);
  ASSERT_EQ(sc.truth.size(), 3u);
  EXPECT_EQ(sc.truth[0].pose, in[0].pose);
  EXPECT_EQ(sc.fits[2].pose, sc.truth[2].pose);
  EXPECT_GT(sc.camera.fx, 0.0f);
  EXPECT_THROW(set_synth_scene_motion(low_body(), sc, {}), Error);
}

int covered(const Image& m) {
  int n = 0;
  for (float x : m.data) n += x > 0;
  return n;
}

TEST(SynthPartMask, CoversTheSkirtWithinThePersonAndNothingWithoutAGarment) {
  SynthMotion motion = make_synth_motion(low_body(), low_subject(), 2, 1, 0);
  const SmplxParams& p = motion.test[0];
  SynthRenderer with(low_body(), low_subject());
  const Camera cam = synth_camera(with, {&p}, 64);
  Image rgb, mask, garment, rgb_plain, mask_plain;
  with.render(cam, p, 2, kSynthAll, rgb, mask, &garment);
  with.render(cam, p, 2, kSynthAll, rgb_plain, mask_plain);
  EXPECT_EQ(rgb.data, rgb_plain.data);  // asking for the part mask changes nothing else
  ASSERT_EQ(garment.width, 64);
  ASSERT_EQ(garment.channels, 1);
  EXPECT_GT(covered(garment), 20);
  EXPECT_LT(covered(garment), covered(mask));
  for (size_t i = 0; i < garment.data.size(); ++i) ASSERT_LE(garment.data[i], mask.data[i] + 1e-6f);
  // Rendering the skirt alone covers at least every pixel the part mask names.
  Image rgb_skirt, mask_skirt;
  with.render(cam, p, 2, kSynthSkirt, rgb_skirt, mask_skirt);
  for (size_t i = 0; i < garment.data.size(); ++i) ASSERT_LE(garment.data[i], mask_skirt.data[i] + 1e-6f);

  SynthSubjectOptions so;
  so.texture_size = 64;
  so.skirt = false;
  const SynthSubject bare = make_synth_subject(low_body(), so);
  SynthRenderer without(low_body(), bare);
  without.render(cam, p, 2, kSynthAll, rgb, mask, &garment);
  EXPECT_GT(covered(mask), 100);
  EXPECT_EQ(covered(garment), 0);
}

}  // namespace
}  // namespace haha
