// The texture's charts (which texels are content) and the speckle measure over the neck,
// hands and feet: properties on the low-resolution procedural body.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "render/texture_charts.h"
#include "render/texture_speckle.h"
#include "support/expect_error.h"
#include "support/low_body.h"

using namespace haha;

namespace {

// Whether texel (i, j)'s centre lies in face f's UV triangle (edges included), directly.
bool centre_in_face(const BodyModel& b, int f, int i, int j, int W, int H) {
  double x[3], y[3];
  for (int k = 0; k < 3; ++k) {
    const int32_t t = b.ft[size_t(f) * 3 + k];
    x[k] = b.vt[2 * size_t(t)] * W - 0.5;
    y[k] = (1.0 - b.vt[2 * size_t(t) + 1]) * H - 0.5;
  }
  const double area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
  if (area == 0) return false;
  for (int k = 0; k < 3; ++k) {
    const int a = k, c = (k + 1) % 3;
    if (((x[c] - x[a]) * (j - y[a]) - (y[c] - y[a]) * (i - x[a])) * area < 0) return false;
  }
  return true;
}

}  // namespace

TEST(TextureCharts, ChartTexelsAreExactlyThoseInsideSomeUvTriangle) {
  const BodyModel& b = test::low_body();
  const int W = 48, H = 40;  // not square: rows and columns must not be swapped
  const TextureCharts c = texture_charts(b, W, H);
  ASSERT_EQ(c.face.size(), size_t(W) * H);
  int64_t inside = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const int32_t f = c.face[size_t(j) * W + i];
      bool any = false;
      for (int g = 0; g < b.num_faces && !any; ++g) any = centre_in_face(b, g, i, j, W, H);
      EXPECT_EQ(f >= 0, any) << "texel " << i << "," << j;
      if (f >= 0) {
        EXPECT_TRUE(centre_in_face(b, f, i, j, W, H));
        ++inside;
      }
    }
  EXPECT_EQ(c.count(), inside);
  EXPECT_GT(inside, int64_t(W) * H / 10);      // a body's atlas is mostly charts...
  EXPECT_LT(inside, int64_t(W) * H);           // ...with a gutter between them
  ASSERT_EQ(c.island.size(), size_t(b.num_faces));
}

TEST(TextureCharts, RejectsBadInput) {
  BodyModel b = test::low_body();
  test::expect_error([&] { texture_charts(b, 0, 8); }, {"texture_charts"});
  b.ft.clear();
  test::expect_error([&] { texture_charts(b, 8, 8); }, {"texture_charts"});
}

TEST(TextureSpeckle, EveryPartHasFacesAndTheSkinDecidesWhich) {
  const BodyModel& b = test::low_body();
  const std::vector<int8_t> part = speckle_face_parts(b);
  int count[3] = {0, 0, 0};
  for (int f = 0; f < b.num_faces; ++f) {
    if (part[size_t(f)] < 0) continue;
    ++count[part[size_t(f)]];
    // The part's joints hold the largest summed weight of the face's corners.
    double best = 0, in_part = 0;
    for (int j = 0; j < 55; ++j) {
      double w = 0;
      for (int k = 0; k < 3; ++k) w += b.weights[size_t(b.faces[size_t(f) * 3 + k]) * 55 + j];
      best = std::max(best, w);
      const bool member = part[size_t(f)] == kSpeckleNeck ? j == 12
                          : part[size_t(f)] == kSpeckleHands ? (j == 20 || j == 21 || j >= 25)
                                                              : (j == 7 || j == 8 || j == 10 || j == 11);
      if (member) in_part = std::max(in_part, w);
    }
    EXPECT_EQ(in_part, best) << "face " << f;
  }
  for (int p = 0; p < 3; ++p) EXPECT_GT(count[p], 0) << speckle_part_name(p);
}

TEST(TextureSpeckle, CountsExactlyTheFlippedTexelsAndIgnoresTheGutter) {
  const BodyModel& b = test::low_body();
  const int S = 128;
  const TextureCharts c = texture_charts(b, S, S);
  const std::vector<int8_t> part = speckle_face_parts(b);
  std::mt19937 rng(3);
  std::vector<float> tex(size_t(S) * S * 3, 0.5f);
  for (size_t t = 0; t < c.face.size(); ++t)  // the gutter is noise: not content, not counted
    if (c.face[t] < 0)
      for (int ch = 0; ch < 3; ++ch) tex[3 * t + ch] = float(rng() % 2);
  TextureSpeckle clean = texture_speckle(tex.data(), c, part);
  for (int p = 0; p < 3; ++p) {
    EXPECT_GT(clean.texels[size_t(p)], 0);
    EXPECT_EQ(clean.per_mille[size_t(p)], 0.0) << speckle_part_name(p);
  }
  // Every 16th chart texel white (sparse: a 5x5 median stays grey, each flip counts).
  int64_t flipped[3] = {0, 0, 0}, n = 0;
  for (size_t t = 0; t < c.face.size(); ++t) {
    if (c.face[t] < 0 || n++ % 16) continue;
    for (int ch = 0; ch < 3; ++ch) tex[3 * t + ch] = 1.0f;
    if (part[size_t(c.face[t])] >= 0) ++flipped[part[size_t(c.face[t])]];
  }
  const TextureSpeckle s = texture_speckle(tex.data(), c, part);
  EXPECT_DOUBLE_EQ(s.all_per_mille, 1000.0 * double((n + 15) / 16) / double(c.count()));
  EXPECT_EQ(clean.all_per_mille, 0.0);
  for (int p = 0; p < 3; ++p) {
    EXPECT_GT(flipped[p], 0);
    EXPECT_DOUBLE_EQ(s.per_mille[size_t(p)], 1000.0 * double(flipped[p]) / double(s.texels[size_t(p)]));
  }
  // A step below the threshold is no speckle.
  for (size_t t = 0; t < c.face.size(); ++t)
    if (tex[3 * t] == 1.0f && c.face[t] >= 0) tex[3 * t] = tex[3 * t + 1] = tex[3 * t + 2] = 0.6f;
  const TextureSpeckle low = texture_speckle(tex.data(), c, part);
  for (int p = 0; p < 3; ++p) EXPECT_EQ(low.per_mille[size_t(p)], 0.0);
  test::expect_error([&] { texture_speckle(b, tex, S, S + 1); }, {"texture_speckle"});
}
