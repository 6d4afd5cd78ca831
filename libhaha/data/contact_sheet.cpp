#include "data/contact_sheet.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {
namespace {

void check_tile(const Image& im, size_t i) {
  if (im.empty() || im.width < 1 || im.height < 1)
    fail("contact sheet", "tile " + std::to_string(i) + " has an empty image");
  if (im.channels != 1 && im.channels != 3 && im.channels != 4)
    fail("contact sheet", "tile " + std::to_string(i) + " has " + std::to_string(im.channels) +
                              " channels (expected 1, 3 or 4)");
  if (im.data.size() != size_t(im.width) * im.height * im.channels)
    fail("contact sheet", "tile " + std::to_string(i) + " has a wrong pixel count");
}

}  // namespace

Image make_contact_sheet(const std::vector<ContactSheetTile>& tiles, const ContactSheetOptions& opt) {
  if (tiles.empty()) fail("contact sheet", "no tiles");
  if (opt.columns < 1) fail("contact sheet", "columns must be at least 1");
  if (opt.padding < 0 || opt.label_scale < 1 || opt.max_tile < 0) fail("contact sheet", "bad padding, label scale or max tile");

  // Shrink large tiles (area filter, aspect kept).
  std::vector<Image> shrunk(tiles.size());
  std::vector<const Image*> im(tiles.size());
  bool any_label = false;
  for (size_t i = 0; i < tiles.size(); ++i) {
    const Image& t = tiles[i].image;
    check_tile(t, i);
    any_label = any_label || !tiles[i].label.empty();
    im[i] = &t;
    if (opt.max_tile > 0 && (t.width > opt.max_tile || t.height > opt.max_tile)) {
      const double s = std::min(double(opt.max_tile) / t.width, double(opt.max_tile) / t.height);
      shrunk[i] = resize_area(t, std::max(1, int(std::lround(t.width * s))), std::max(1, int(std::lround(t.height * s))));
      im[i] = &shrunk[i];
    }
  }
  int cell_w = 0, cell_h = 0;
  for (const Image* p : im) cell_w = std::max(cell_w, p->width), cell_h = std::max(cell_h, p->height);
  const int pad = opt.padding, sc = opt.label_scale;
  const int label_h = any_label ? kFontHeight * sc + 2 * sc + 1 : 0;
  const int title_h = opt.title.empty() ? 0 : kFontHeight * sc + pad;

  // Grid positions: row-major, new_row starts a fresh row.
  std::vector<std::pair<int, int>> pos(tiles.size());
  int row = 0, col = 0, columns_used = 0;
  for (size_t i = 0; i < tiles.size(); ++i) {
    if ((tiles[i].new_row && col > 0) || col == opt.columns) {
      ++row;
      col = 0;
    }
    pos[i] = {row, col};
    columns_used = std::max(columns_used, col + 1);
    ++col;
  }
  const int rows = row + 1;
  const int W = pad + columns_used * (cell_w + pad);
  const int H = pad + title_h + rows * (cell_h + label_h + pad);
  if (int64_t(W) * H > (int64_t(1) << 28)) fail("contact sheet", "sheet would be too large; set max_tile");

  Image sheet(W, H, 3);
  for (int p = 0; p < W * H; ++p)
    for (int c = 0; c < 3; ++c) sheet.data[size_t(p) * 3 + c] = opt.background[c];
  if (!opt.title.empty()) draw_text(sheet, pad, pad, opt.title, opt.text, sc);

  for (size_t i = 0; i < tiles.size(); ++i) {
    const Image& t = *im[i];
    const int cx = pad + pos[i].second * (cell_w + pad);
    const int cy = pad + title_h + pos[i].first * (cell_h + label_h + pad);
    const int ox = cx + (cell_w - t.width) / 2, oy = cy + (cell_h - t.height) / 2;
    for (int y = 0; y < t.height; ++y)
      for (int x = 0; x < t.width; ++x) {
        float* d = &sheet.data[(size_t(oy + y) * W + ox + x) * 3];
        const float* s = &t.data[(size_t(y) * t.width + x) * t.channels];
        if (t.channels == 1) {
          d[0] = d[1] = d[2] = s[0];
        } else {
          const float a = t.channels == 4 ? s[3] : 1.0f;
          for (int c = 0; c < 3; ++c) d[c] = a * s[c] + (1 - a) * d[c];
        }
      }
    if (!tiles[i].label.empty()) {
      // Clip the label to its cell: draw into a cell-wide strip, then copy.
      Image strip(cell_w, label_h, 3);
      for (size_t k = 0; k < strip.data.size(); ++k) strip.data[k] = opt.background[k % 3];
      const int tw = text_width(tiles[i].label, sc);
      draw_text(strip, std::max(0, (cell_w - tw) / 2), sc + 1, tiles[i].label, opt.text, sc);
      for (int y = 0; y < label_h; ++y)
        std::copy_n(&strip.data[size_t(y) * cell_w * 3], size_t(cell_w) * 3,
                    &sheet.data[(size_t(cy + cell_h + y) * W + cx) * 3]);
    }
  }
  return sheet;
}

void write_contact_sheet(const std::string& path, const std::vector<ContactSheetTile>& tiles,
                         const ContactSheetOptions& opt) {
  write_image(path, make_contact_sheet(tiles, opt));
}

}  // namespace haha
