// Images in memory (libhaha/core/image.h): area resampling (block means, the mean kept at
// any ratio, identity, up- and downscaling to odd sizes, one pixel), crops (inside, whole,
// corners, outside), rounding to what an 8-bit file holds, RGB from any channel count a
// file may hold.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "core/error.h"
#include "core/image.h"
#include "support/image_pattern.h"

namespace haha {
namespace {


using haha::test::pattern;

TEST(ImageResample, AreaAverageProperties) {
  const Image img = pattern(12, 8, 3);
  // Exact 2x downscale = 2x2 block means.
  const Image half = resize_area(img, 6, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x)
      for (int k = 0; k < 3; ++k) {
        const float m = 0.25f * (img.at(2 * x, 2 * y, k) + img.at(2 * x + 1, 2 * y, k) + img.at(2 * x, 2 * y + 1, k) +
                                 img.at(2 * x + 1, 2 * y + 1, k));
        EXPECT_NEAR(half.at(x, y, k), m, 1e-6f);
      }
  // Any ratio preserves the mean (each output pixel averages the area it covers).
  for (auto [w, h] : {std::pair{5, 3}, std::pair{7, 7}, std::pair{12, 8}, std::pair{25, 17}}) {
    const Image r = resize_area(img, w, h);
    for (int k = 0; k < 3; ++k) {
      double a = 0, b = 0;
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 12; ++x) a += img.at(x, y, k);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) b += r.at(x, y, k);
      EXPECT_NEAR(a / (12 * 8), b / (w * h), 1e-5) << w << "x" << h;
    }
  }
  // Same size is the identity; a constant stays constant.
  EXPECT_EQ(resize_area(img, 12, 8).data, img.data);
  const Image c = resize_area(Image(9, 5, 1, 0.3f), 4, 3);
  for (float v : c.data) EXPECT_NEAR(v, 0.3f, 1e-6f);
}

TEST(ImageResample, CropCopiesTheRectangle) {
  const Image img = pattern(8, 12, 2);
  const Image c = crop(img, 1, 2, 5, 7);
  ASSERT_EQ(c.width, 5);
  ASSERT_EQ(c.height, 7);
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 5; ++x)
      for (int k = 0; k < 2; ++k) EXPECT_EQ(c.at(x, y, k), img.at(x + 1, y + 2, k));
  EXPECT_THROW(crop(img, 4, 0, 5, 1), Error);
}


TEST(ImageResample, UnevenRatiosWeighTheCoveredArea) {
  // 3 -> 2 pixels: output 0 covers source [0, 1.5), output 1 covers [1.5, 3).
  Image row(3, 1, 1);
  row.data = {0.0f, 0.3f, 0.9f};
  const Image r = resize_area(row, 2, 1);
  EXPECT_NEAR(r.data[0], (0.0f + 0.5f * 0.3f) / 1.5f, 1e-6f);
  EXPECT_NEAR(r.data[1], (0.5f * 0.3f + 0.9f) / 1.5f, 1e-6f);
  // To one pixel: the mean of everything, per channel.
  Image two(2, 3, 2);
  for (int i = 0; i < 12; ++i) two.data[size_t(i)] = float(i);
  const Image one = resize_area(two, 1, 1);
  ASSERT_EQ(one.data.size(), 2u);
  EXPECT_NEAR(one.data[0], (0 + 2 + 4 + 6 + 8 + 10) / 6.0f, 1e-5f);
  EXPECT_NEAR(one.data[1], (1 + 3 + 5 + 7 + 9 + 11) / 6.0f, 1e-5f);
}

TEST(ImageResample, UpscalingRepeatsPixelsAndBlendsOnlyAtSharedEdges) {
  // 1 pixel up to any size: constant.
  Image dot(1, 1, 3);
  dot.data = {0.1f, 0.5f, 0.9f};
  const Image big = resize_area(dot, 7, 5);
  ASSERT_EQ(big.width, 7);
  ASSERT_EQ(big.height, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(big.at(x, y, k), dot.data[size_t(k)], 1e-6f);
  // 2 -> 5 (odd): outputs 0, 1 lie in source pixel 0, 3, 4 in pixel 1, output 2 straddles
  // the edge half and half.
  Image row(2, 1, 1);
  row.data = {0.0f, 1.0f};
  const Image r = resize_area(row, 5, 1);
  EXPECT_NEAR(r.data[0], 0.0f, 1e-6f);
  EXPECT_NEAR(r.data[1], 0.0f, 1e-6f);
  EXPECT_NEAR(r.data[2], 0.5f, 1e-6f);
  EXPECT_NEAR(r.data[3], 1.0f, 1e-6f);
  EXPECT_NEAR(r.data[4], 1.0f, 1e-6f);
}

TEST(ImageResample, EmptyImageOrSizeIsAnError) {
  EXPECT_THROW(resize_area(Image(), 4, 4), Error);
  EXPECT_THROW(resize_area(Image(4, 4, 1), 0, 4), Error);
  EXPECT_THROW(resize_area(Image(4, 4, 1), 4, -1), Error);
}

TEST(ImageCrop, WholeImageCornersAndEdges) {
  const Image img = pattern(5, 3, 3);
  EXPECT_EQ(crop(img, 0, 0, 5, 3).data, img.data);
  const Image corner = crop(img, 4, 2, 1, 1);  // the last pixel
  ASSERT_EQ(corner.data.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(corner.data[size_t(k)], img.at(4, 2, k));
  const Image column = crop(img, 4, 0, 1, 3);
  for (int y = 0; y < 3; ++y) EXPECT_EQ(column.at(0, y, 1), img.at(4, y, 1));
  // One pixel past any border, a negative origin, an empty rectangle: errors.
  EXPECT_THROW(crop(img, 0, 0, 6, 3), Error);
  EXPECT_THROW(crop(img, 0, 1, 5, 3), Error);
  EXPECT_THROW(crop(img, -1, 0, 2, 2), Error);
  EXPECT_THROW(crop(img, 0, -1, 2, 2), Error);
  EXPECT_THROW(crop(img, 1, 1, 0, 1), Error);
  EXPECT_THROW(crop(Image(), 0, 0, 1, 1), Error);
}

TEST(ImageRound, To8BitClampsAndRoundsToTheNearestCode) {
  Image img(6, 1, 1);
  img.data = {-0.5f, 0.0f, 0.5f / 255.0f - 1e-4f, 127.5f / 255.0f + 1e-4f, 1.0f, 7.0f};
  round_to_8bit(img);
  EXPECT_EQ(img.data[0], 0.0f);
  EXPECT_EQ(img.data[1], 0.0f);
  EXPECT_EQ(img.data[2], 0.0f);
  EXPECT_NEAR(img.data[3], 128.0f / 255.0f, 1e-7f);
  EXPECT_EQ(img.data[4], 1.0f);
  EXPECT_EQ(img.data[5], 1.0f);
  // Idempotent: a rounded image is already what a file holds.
  const Image once = img;
  round_to_8bit(img);
  EXPECT_EQ(img.data, once.data);
}

TEST(ImageToRgb, GreyGreyAlphaRgbAndRgbaBecomeRgbAndOtherCountsAreErrors) {
  for (int ch : {1, 2, 3, 4}) {
    Image img(2, 1, ch);
    for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = 0.1f * float(i + 1);
    const Image rgb = to_rgb(img, "x.png");
    ASSERT_EQ(rgb.channels, 3);
    ASSERT_EQ(rgb.width, 2);
    for (int x = 0; x < 2; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(rgb.at(x, 0, c), img.at(x, 0, ch >= 3 ? c : 0)) << ch << " channels, pixel " << x << " channel " << c;
  }
  for (int ch : {0, 5}) {
    Image img;
    img.width = img.height = 1;
    img.channels = ch;
    img.data.assign(size_t(ch), 0.5f);
    try {
      to_rgb(img, "x.exr");
      ADD_FAILURE() << ch << " channels accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("x.exr"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(std::to_string(ch) + " channels"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace haha
