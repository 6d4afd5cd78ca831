// Background-aware matting on synthetic frames: a disc of known colour F with a soft edge
// of known alpha moves over a known textured backdrop B; the frames are I = a F + (1 - a) B
// in 8 bits, and the "tool's" mask is wider and softer than the truth (it leaks backdrop).
// The plate is B where uncovered, a static camera is static and a shifted one moves, a
// region the person never leaves is a hole, and the refined alpha and a F are near the truth.
#include <gtest/gtest.h>

#include <cmath>

#include "data/background_matting.h"
#include "support/expect_error.h"

namespace haha {
namespace {

constexpr int kW = 160, kH = 96;
constexpr double kR = 12;  // the disc's radius, px

bool g_plain_wall = false;  // a smooth wall instead of the textured one
float backdrop(int x, int y, int c) {  // a bright wall with a texture a camera shift shows
  if (g_plain_wall) return float(0.86 + 0.02 * c - 0.0004 * x + 0.0002 * y);
  return float(0.82 + 0.02 * c + 0.1 * std::sin(x / 3.0) * std::cos(y / 4.0));
}
float foreground(int x, int y, int c) {  // the person's colour: dark red with a gradient
  const float v[3] = {float(0.55 + 0.15 * std::sin(y / 9.0)), 0.22f, float(0.18 + 0.08 * std::cos(x / 11.0))};
  return v[c];
}
double dist(int x, int y, double cx) { return std::hypot(x + 0.5 - cx, y + 0.5 - kH / 2.0); }
// The true alpha: 1 inside, a 3 px ramp at the edge.
float true_alpha(int x, int y, double cx) { return float(std::clamp((kR + 1.5 - dist(x, y, cx)) / 3.0, 0.0, 1.0)); }
// The tool's mask: 0.5 three pixels outside the true edge, a 6 px ramp (backdrop leaks in).
float tool_mask(int x, int y, double cx) {
  return float(std::clamp((kR + 3 - dist(x, y, cx)) / 6.0 + 0.5, 0.0, 1.0));
}
float quantize(double v) { return float(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)) / 255.0f; }

struct Frame {
  Image rgb, mask;
};
// The disc at cx over the backdrop shifted `shift` px to the left, with +-`noise` / 255 of
// deterministic noise.
Frame make_frame(double cx, int shift = 0, int noise = 0, int seed = 0) {
  Frame f{Image(kW, kH, 3), Image(kW, kH, 1)};
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const float a = true_alpha(x, y, cx);
      f.mask.at(x, y, 0) = tool_mask(x, y, cx);
      for (int c = 0; c < 3; ++c) {
        const int n = noise ? int((x * 7 + y * 13 + c * 5 + seed * 31) % (2 * noise + 1)) - noise : 0;
        f.rgb.at(x, y, c) = quantize(a * foreground(x, y, c) + (1 - a) * backdrop(x + shift, y, c) + n / 255.0);
      }
    }
  return f;
}

MattingOptions options() {
  MattingOptions o;
  o.band_px = 6;
  return o;
}

BackgroundPlate plate_of(const std::vector<double>& centres, int shift_per_frame = 0, int noise = 0) {
  BackgroundPlateBuilder b(kW, kH, options());
  for (size_t i = 0; i < centres.size(); ++i) {
    const Frame f = make_frame(centres[i], int(i) * shift_per_frame, noise, int(i));
    b.add(f.rgb, f.mask);
  }
  EXPECT_EQ(b.frames(), int(centres.size()));
  return b.build();
}

// The disc crosses the frame: every pixel is uncovered in some frames.
std::vector<double> crossing() {
  std::vector<double> c;
  for (int i = 0; i < 10; ++i) c.push_back(20 + i * 120.0 / 9);
  return c;
}

TEST(BackgroundMatting, PlateIsTheBackdropWhereUncovered) {
  const BackgroundPlate p = plate_of(crossing());
  EXPECT_EQ(p.frames, 10);
  EXPECT_EQ(p.hole_share, 0.0);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(p.rgb.at(x, y, c), quantize(backdrop(x, y, c))) << x << ", " << y;
  EXPECT_LT(p.residual, 1e-9);
  EXPECT_TRUE(p.camera_static(options()));
}

TEST(BackgroundMatting, NoiseOfAStaticCameraIsStaticAShiftMoves) {
  const BackgroundPlate quiet = plate_of(crossing(), 0, 2);
  EXPECT_LT(quiet.residual, 2.0 / 255) << "codec-like noise of +-2/255";
  EXPECT_TRUE(quiet.camera_static(options()));
  const BackgroundPlate moving = plate_of(crossing(), 5);  // the backdrop moves 5 px a frame
  EXPECT_GT(moving.residual, options().static_threshold) << moving.residual;
  EXPECT_FALSE(moving.camera_static(options()));
  ASSERT_EQ(moving.frame_residual.size(), 10u);
}

TEST(BackgroundMatting, ARegionThePersonNeverLeavesIsAHole) {
  std::vector<double> c;
  for (int i = 0; i < 10; ++i) c.push_back(70 + i * 20.0 / 9);  // sways by 20 px around x = 80
  const BackgroundPlate p = plate_of(c);
  EXPECT_FALSE(p.known[size_t(kH / 2) * kW + 80]);
  EXPECT_TRUE(p.known[size_t(5) * kW + 5]);
  // Covered in every frame: within ~30 px (the mask's 18 plus the dilation's 12) of x = 70
  // and of x = 90: a lens of about 1650 px of 15360.
  EXPECT_GT(p.hole_share, 0.08);
  EXPECT_LT(p.hole_share, 0.14);
  // In a hole of the plate the tool's mask stays.
  const Frame f = make_frame(80);
  const Matte m = refine_matte(f.rgb, f.mask, p, options());
  const int x = int(80 + kR + 2), y = kH / 2;  // in the band, inside the hole
  ASSERT_FALSE(p.known[size_t(y) * kW + x]);
  EXPECT_EQ(m.alpha.at(x, y, 0), f.mask.at(x, y, 0));
  EXPECT_LT(m.band_known, 1.0);
  EXPECT_EQ(p.filled_share, 0.0) << "next to texture the holes stay holes";
}

TEST(BackgroundMatting, HolesNextToAPlainWallAreFilledAndMatted) {
  g_plain_wall = true;
  std::vector<double> c;
  for (int i = 0; i < 10; ++i) c.push_back(70 + i * 20.0 / 9);  // the person never leaves x = 80
  const BackgroundPlate p = plate_of(c);
  EXPECT_GT(p.hole_share, 0.08);
  EXPECT_NEAR(p.filled_share, p.hole_share, 1e-9) << "every hole is within reach of the wall";
  EXPECT_EQ(p.known[size_t(kH / 2) * kW + 80], 2);
  const double cx = 80;
  const Frame f = make_frame(cx);
  const Matte m = refine_matte(f.rgb, f.mask, p, options());
  EXPECT_GT(m.band_filled, 0.3);
  double err = 0, tool_err = 0;
  int n = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double d = dist(x, y, cx);
      if (d < kR - 3 || d > kR + 3 || p.known[size_t(y) * kW + x] != 2) continue;
      err += std::abs(m.alpha.at(x, y, 0) - true_alpha(x, y, cx));
      tool_err += std::abs(f.mask.at(x, y, 0) - true_alpha(x, y, cx));
      ++n;
    }
  g_plain_wall = false;
  ASSERT_GT(n, 50);
  EXPECT_LT(err / n, 0.06) << "the tool's mask: " << tool_err / n;
  EXPECT_LT(err, 0.3 * tool_err);
}

TEST(BackgroundMatting, AlphaAndPremultipliedColourAreRecoveredAtSoftEdges) {
  const BackgroundPlate p = plate_of(crossing());
  const double cx = 73;
  const Frame f = make_frame(cx);
  const Matte m = refine_matte(f.rgb, f.mask, p, options());
  ASSERT_EQ(m.alpha.width, kW);
  ASSERT_EQ(m.premultiplied.channels, 3);
  EXPECT_EQ(m.band_known, 1.0);
  double err = 0, tool_err = 0, err_af = 0, tool_err_af = 0;
  int n = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const float a = true_alpha(x, y, cx);
      const double d = dist(x, y, cx);
      if (d > kR + 12) {
        EXPECT_EQ(m.alpha.at(x, y, 0), 0.0f) << x << ", " << y;  // outside the dilated mask
        continue;
      }
      if (d < kR - 6) {
        EXPECT_EQ(m.alpha.at(x, y, 0), 1.0f) << x << ", " << y;  // the core
        continue;
      }
      if (d < kR - 3 || d > kR + 3) continue;  // the soft edge and a little beside it
      err += std::abs(m.alpha.at(x, y, 0) - a);
      tool_err += std::abs(f.mask.at(x, y, 0) - a);
      for (int c = 0; c < 3; ++c) {
        const double truth = a * foreground(x, y, c);
        EXPECT_LE(m.premultiplied.at(x, y, c), m.alpha.at(x, y, 0) + 1e-6f);
        err_af += std::abs(m.premultiplied.at(x, y, c) - truth) / 3;
        tool_err_af += std::abs(f.mask.at(x, y, 0) * f.rgb.at(x, y, c) - truth) / 3;
      }
      ++n;
    }
  ASSERT_GT(n, 100);
  err /= n, tool_err /= n, err_af /= n, tool_err_af /= n;
  EXPECT_LT(err, 0.06) << "the tool's mask: " << tool_err;
  EXPECT_LT(err, 0.3 * tool_err);
  EXPECT_LT(err_af, 0.03) << "mask x image: " << tool_err_af;
  EXPECT_LT(err_af, 0.3 * tool_err_af);
}

TEST(BackgroundMatting, WithoutAPlateTheToolsMaskStays) {
  const Frame f = make_frame(60);
  const Matte m = refine_matte(f.rgb, f.mask, BackgroundPlate{}, options());
  EXPECT_EQ(m.alpha.data, f.mask.data);
  EXPECT_FLOAT_EQ(m.premultiplied.at(60, kH / 2, 1), f.rgb.at(60, kH / 2, 1) * f.mask.at(60, kH / 2, 0));
}

TEST(BackgroundMatting, FramesWithNobodyAndBadSizes) {
  BackgroundPlateBuilder b(8, 6, options());
  b.add(Image(8, 6, 3, 0.5f), Image());  // nobody: every pixel is background
  const BackgroundPlate p = b.build();
  EXPECT_EQ(p.hole_share, 0.0);
  EXPECT_FLOAT_EQ(p.rgb.at(3, 3, 0), quantize(0.5));
  test::expect_error_at("background plate", [&] { b.add(Image(7, 6, 3), Image()); }, {"7x6", "8x6"});
  test::expect_error_at("background plate", [&] { b.add(Image(8, 6, 3), Image(8, 6, 3)); }, {"one channel"});
  test::expect_error_at("matting", [&] { refine_matte(Image(8, 6, 3), Image(8, 5, 1), p); }, {"8x5"});
  test::expect_error_at("matting", [&] { refine_matte(Image(4, 6, 3), Image(4, 6, 1), p); }, {"plate"});
}

}  // namespace
}  // namespace haha
