// A deterministic test image: every pixel and channel a different value in [0, 1].
#pragma once

#include "core/image.h"

namespace haha::test {

inline Image pattern(int w, int h, int c) {
  Image img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = float((x * 37 + y * 11 + k * 101) % 256) / 255.0f;
  return img;
}

}  // namespace haha::test
