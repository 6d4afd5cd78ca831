// Contact sheets (libhaha/data/contact_sheet.cpp): grid layout, rows, labels, shrinking,
// bad input.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "data/contact_sheet.h"
#include "support/expect_error.h"

namespace haha {
namespace {

using haha::test::expect_error;


TEST(ContactSheet, GridLayoutRowsLabelsAndShrinking) {
  std::vector<ContactSheetTile> tiles;
  for (int i = 0; i < 5; ++i) {
    ContactSheetTile t;
    t.image = Image(20, 10, 3, 0.5f);
    t.label = "T" + std::to_string(i);
    tiles.push_back(t);
  }
  tiles[3].new_row = true;  // rows: [0 1 2] [3 4]
  ContactSheetOptions o;
  o.columns = 4;
  o.padding = 2;
  const Image s = make_contact_sheet(tiles, o);
  const int label_h = kFontHeight + 3;
  EXPECT_EQ(s.width, 2 + 3 * (20 + 2));
  EXPECT_EQ(s.height, 2 + 2 * (10 + label_h + 2));
  EXPECT_EQ(s.channels, 3);
  // Tile pixels copied, label text drawn under the first tile.
  EXPECT_FLOAT_EQ(s.at(2 + 5, 2 + 5, 1), 0.5f);
  int text = 0;
  for (int y = 2 + 10; y < 2 + 10 + label_h; ++y)
    for (int x = 2; x < 22; ++x) text += s.at(x, y, 0) > 0.9f;
  EXPECT_GT(text, 5);
  // Shrinking keeps the aspect; grey and RGBA tiles are accepted.
  tiles.clear();
  tiles.push_back({Image(200, 100, 1, 1.0f), "", false});
  tiles.push_back({Image(50, 50, 4, 1.0f), "", false});
  o.max_tile = 40;
  const Image s2 = make_contact_sheet(tiles, o);
  EXPECT_EQ(s2.width, 2 + 2 * (40 + 2));
  EXPECT_EQ(s2.height, 2 + 40 + 2);
}

TEST(ContactSheet, BadInputIsAnError) {
  expect_error([] { make_contact_sheet({}); }, "no tiles");
  expect_error([] { make_contact_sheet({{Image(), "x", false}}); }, "empty image");
  expect_error([] { make_contact_sheet({{Image(4, 4, 2), "x", false}}); }, "channels");
  ContactSheetOptions o;
  o.columns = 0;
  expect_error([&] { make_contact_sheet({{Image(4, 4, 3), "x", false}}, o); }, "columns");
}

}  // namespace
}  // namespace haha
