#include "train/outline_band.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "train/losses.h"

namespace haha {
namespace {

// A W x H mask with an axis-aligned square of person [r0, r1) x [c0, c1).
std::vector<float> square(int H, int W, int r0, int r1, int c0, int c1) {
  std::vector<float> m(size_t(H) * W, 0.0f);
  for (int r = r0; r < r1; ++r)
    for (int c = c0; c < c1; ++c) m[size_t(r) * W + c] = 1.0f;
  return m;
}

TEST(OutlineBand, SquareBandHasTheExpectedWidthOnBothSides) {
  const int H = 40, W = 40;
  const std::vector<float> m = square(H, W, 10, 30, 10, 30);
  const std::vector<float> b = outline_band(m.data(), H, W, 3);
  // Along row 20: outline pixels at columns 9 (outside) and 10 (inside); the band reaches
  // 3 px further on each side: columns 6..13 on the left edge.
  for (int c = 0; c < 20; ++c) EXPECT_EQ(b[size_t(20) * W + c], (c >= 6 && c <= 13) ? 1.0f : 0.0f) << c;
  // The square's centre and a far corner are outside the band.
  EXPECT_EQ(b[size_t(20) * W + 20], 0.0f);
  EXPECT_EQ(b[0], 0.0f);
}

TEST(OutlineBand, RadiusZeroIsTheOutlineItself) {
  const int H = 12, W = 12;
  const std::vector<float> m = square(H, W, 4, 8, 4, 8);
  const std::vector<float> b = outline_band(m.data(), H, W, 0);
  int n = 0;
  for (float v : b) n += v > 0;
  // 4x4 square: its 12 border pixels inside + 16 4-neighbours outside.
  EXPECT_EQ(n, 12 + 16);
}

TEST(OutlineBand, UniformMasksHaveNoOutline) {
  const int H = 8, W = 9;
  for (float v : {0.0f, 1.0f, 0.5f}) {  // 0.5 is not above the threshold: background
    const std::vector<float> m(size_t(H) * W, v);
    for (float x : outline_band(m.data(), H, W, 3)) EXPECT_EQ(x, 0.0f);
  }
  EXPECT_TRUE(outline_band(nullptr, 0, 0, 3).empty());
}

TEST(OutlineBand, SoftEdgesAreSplitAtOneHalfAndTheFrameBorderIsNoOutline) {
  // Person filling the left half with a soft ramp; the frame's own border is not an edge.
  const int H = 6, W = 10;
  std::vector<float> m(size_t(H) * W, 0.0f);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) m[size_t(r) * W + c] = c < 4 ? 1.0f : c == 4 ? 0.6f : c == 5 ? 0.4f : 0.0f;
  const std::vector<float> b = outline_band(m.data(), H, W, 1);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) EXPECT_EQ(b[size_t(r) * W + c], (c >= 3 && c <= 6) ? 1.0f : 0.0f) << r << "," << c;
}

TEST(OutlineBand, PsnrInsideTheBandSeesAFringeTheWholeFrameHides) {
  // A one-pixel light fringe around a dark square: the whole-frame PSNR stays high, the band's
  // PSNR shows it.
  const int H = 64, W = 64;
  const std::vector<float> m = square(H, W, 16, 48, 16, 48);
  std::vector<float> truth(size_t(H) * W * 3, 0.0f), render;
  for (size_t p = 0; p < m.size(); ++p)
    for (int c = 0; c < 3; ++c) truth[3 * p + c] = 0.2f * m[p];
  render = truth;
  const std::vector<float> ring = outline_band(m.data(), H, W, 0);
  for (size_t p = 0; p < m.size(); ++p)
    if (ring[p] > 0 && m[p] < 0.5f)
      for (int c = 0; c < 3; ++c) render[3 * p + c] = 0.8f;
  const std::vector<float> band = outline_band(m.data(), H, W, 3);
  const double whole = psnr(render.data(), truth.data(), H, W);
  const double edge = psnr(render.data(), truth.data(), H, W, band.data());
  // The same squared error over fewer pixels: lower by 10 log10(frame / band pixels), > 5 dB.
  double n = 0;
  for (float v : band) n += v;
  EXPECT_NEAR(whole - edge, 10.0 * std::log10(double(H) * W / n), 1e-9);
  EXPECT_GT(whole - edge, 5.0);
}

TEST(OutlineBand, BadArgumentsThrow) {
  const float m = 1.0f;
  EXPECT_THROW(outline_band(&m, 1, 1, -1), Error);
  EXPECT_THROW(outline_band(&m, -1, 1, 1), Error);
}

}  // namespace
}  // namespace haha
