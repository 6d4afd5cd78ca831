// The built-in bitmap font (libhaha/core/bitmap_font.cpp): distinct glyphs, case folding,
// unknown characters as '?', text widths, drawing inside its box and clipped at the border.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "core/bitmap_font.h"

namespace haha {
namespace {


TEST(BitmapFont, FontHasDistinctGlyphsAndMapsUnknownToQuestionMark) {
  const std::string chars = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.,:-_/()=+%#!?";
  std::map<std::string, char> seen;
  for (char c : chars) {
    std::string bits;
    int set = 0;
    for (int y = 0; y < kFontHeight; ++y)
      for (int x = 0; x < kFontWidth; ++x) {
        bits += font_pixel(c, x, y) ? '1' : '0';
        set += font_pixel(c, x, y);
      }
    EXPECT_GT(set, 0) << c;
    EXPECT_TRUE(seen.emplace(bits, c).second) << c << " looks like " << seen[bits];
  }
  for (int y = 0; y < kFontHeight; ++y)
    for (int x = 0; x < kFontWidth; ++x) {
      EXPECT_EQ(font_pixel('a', x, y), font_pixel('A', x, y));
      EXPECT_EQ(font_pixel('~', x, y), font_pixel('?', x, y));
      EXPECT_FALSE(font_pixel(' ', x, y));
    }
  EXPECT_FALSE(font_pixel('A', -1, 0));
  EXPECT_FALSE(font_pixel('A', 0, kFontHeight));
  EXPECT_EQ(text_width("", 1), 0);
  EXPECT_EQ(text_width("AB", 1), 11);
  EXPECT_EQ(text_width("AB", 2), 22);
}

TEST(BitmapFont, DrawTextStaysInsideItsBoxAndClipsAtTheBorder) {
  Image img(40, 20, 3, 0.0f);
  const float white[3] = {1, 1, 1};
  draw_text(img, 3, 4, "H1", white, 1);
  int inside = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (img.at(x, y, 0) > 0) {
        EXPECT_TRUE(x >= 3 && x < 3 + text_width("H1") && y >= 4 && y < 4 + kFontHeight) << x << "," << y;
        ++inside;
      }
  EXPECT_GT(inside, 10);
  // Partly outside: no crash, only in-image pixels drawn.
  draw_text(img, -4, -3, "WWW", white, 3);
  draw_text(img, 38, 18, "WWW", white, 3);
  Image grey(8, 8, 1, 0.0f);
  draw_text(grey, 0, 0, "#", white, 1);
  EXPECT_EQ(grey.at(1, 0, 0), 1.0f);
}

}  // namespace
}  // namespace haha
