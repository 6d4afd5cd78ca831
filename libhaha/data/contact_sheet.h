// Contact sheets: many small images tiled into one picture with a text label under each,
// for a person to look at (synthetic data, training progress, evaluation). Labels use the
// built-in bitmap font (core/bitmap_font.h), so no font file or library is needed.
#pragma once

#include <string>
#include <vector>

#include "core/bitmap_font.h"
#include "io/image.h"

namespace haha {

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
