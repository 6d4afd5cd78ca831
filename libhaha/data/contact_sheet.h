// Contact sheets: many small images tiled into one picture with a text label under each,
// for a person to look at (synthetic data, training progress, evaluation). Labels use a
// built-in 5 x 7 bitmap font (ASCII letters, digits and common punctuation; lower case is
// drawn as upper case, anything else as '?'), so no font file or library is needed.
#pragma once

#include <string>
#include <vector>

#include "io/image.h"

namespace haha {

constexpr int kFontWidth = 5, kFontHeight = 7;
constexpr int kFontAdvance = kFontWidth + 1;  // one blank column between characters

// Whether pixel (x, y) of character c's glyph is set; x in [0, 5), y in [0, 7) from the
// top. Outside that box: false.
bool font_pixel(char c, int x, int y);

// Width in pixels of `text` drawn at `scale` (no trailing gap): advance * n - scale.
int text_width(const std::string& text, int scale = 1);

// Draws `text` with its top-left corner at (x, y), each font pixel a scale x scale block of
// colour rgb (1-channel images get the mean of rgb; a 4th channel is set to 1). Clipped to
// the image.
void draw_text(Image& img, int x, int y, const std::string& text, const float rgb[3], int scale = 1);

struct ContactSheetTile {
  Image image;           // 1 (grey), 3 (RGB) or 4 (RGBA, composited over the background) channels
  std::string label;     // drawn under the image (clipped to the cell); may be empty
  bool new_row = false;  // start a new row before this tile (to separate sections)
};

struct ContactSheetOptions {
  int columns = 8;        // tiles per row (>= 1)
  int max_tile = 0;       // > 0: images larger than this on either side are shrunk (area
                          // filter, aspect kept) to fit max_tile x max_tile
  int padding = 4;        // pixels around and between cells
  int label_scale = 1;    // font pixel size
  std::string title;      // optional line above the grid
  float background[3] = {0.12f, 0.12f, 0.12f};
  float text[3] = {0.95f, 0.95f, 0.95f};
};

// Cells are as large as the largest (shrunk) tile; each image is centred in its cell.
// Throws haha::Error ("contact sheet: ...") for no tiles, an empty image, an unsupported
// channel count or bad options.
Image make_contact_sheet(const std::vector<ContactSheetTile>& tiles, const ContactSheetOptions& opt = {});

// make_contact_sheet + write_image (atomic; PNG for a .png path).
void write_contact_sheet(const std::string& path, const std::vector<ContactSheetTile>& tiles,
                         const ContactSheetOptions& opt = {});

}  // namespace haha
