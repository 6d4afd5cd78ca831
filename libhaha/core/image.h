// Images in memory: float pixels, row-major, top row first, channels interleaved, and the
// pixel operations that need no file (io/image.h reads and writes them).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace haha {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> data;  // width * height * channels

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f) : width(w), height(h), channels(c), data(size_t(w) * h * c, fill) {}
  bool empty() const { return data.empty(); }
  float& at(int x, int y, int c) { return data[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return data[(size_t(y) * width + x) * channels + c]; }
};

// Area-weighted resampling: each output pixel is the exact average of the source area it
// covers (pixel-edge convention, so pixel coordinates scale by w/src.width, h/src.height).
Image resize_area(const Image& src, int w, int h);

// RGB from 1 (grey), 2 (grey + alpha: the grey), 3 or 4 (alpha dropped) channels. Throws
// haha::Error "<where>: image has N channels, expected RGB" for any other count.
Image to_rgb(Image img, const std::string& where);

// Sub-rectangle [x0, x0 + w) x [y0, y0 + h); must lie inside the image.
Image crop(const Image& src, int x0, int y0, int w, int h);

// What an 8-bit file (PNG) holds of `img` once written and read back through io/image.h:
// every value clamped to [0, 1] and rounded to the nearest multiple of 1/255. For pixels
// handed over in memory that would otherwise have gone through such a file.
void round_to_8bit(Image& img);

}  // namespace haha
