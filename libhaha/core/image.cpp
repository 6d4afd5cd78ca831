#include "core/image.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {

Image resize_area(const Image& src, int w, int h) {
  if (src.empty() || w <= 0 || h <= 0) throw Error("resize_area: empty image or target size");
  // Per output index, the source pixels it overlaps and their weights (sum 1).
  struct Tap { int i; float w; };
  auto taps = [](int n_src, int n_dst) {
    std::vector<std::vector<Tap>> t(static_cast<size_t>(n_dst));
    const double scale = double(n_src) / n_dst;
    for (int o = 0; o < n_dst; ++o) {
      const double a = o * scale, b = (o + 1) * scale;
      for (int i = int(std::floor(a)); i < std::min(n_src, int(std::ceil(b))); ++i) {
        const double overlap = std::min(b, double(i + 1)) - std::max(a, double(i));
        if (overlap > 0) t[size_t(o)].push_back({i, float(overlap / scale)});
      }
    }
    return t;
  };
  const auto tx = taps(src.width, w), ty = taps(src.height, h);
  const int c = src.channels;
  Image rows(w, src.height, c);
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) {
        float acc = 0;
        for (const Tap& t : tx[size_t(x)]) acc += t.w * src.at(t.i, y, k);
        rows.at(x, y, k) = acc;
      }
  Image out(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) {
        float acc = 0;
        for (const Tap& t : ty[size_t(y)]) acc += t.w * rows.at(x, t.i, k);
        out.at(x, y, k) = acc;
      }
  return out;
}

Image to_rgb(Image img, const std::string& where) {
  if (img.channels == 3) return img;
  if (img.channels < 1 || img.channels > 4)
    fail(where, "image has " + std::to_string(img.channels) + " channels, expected RGB");
  Image out(img.width, img.height, 3);
  const size_t n = size_t(img.width) * size_t(img.height), ch = size_t(img.channels);
  for (size_t p = 0; p < n; ++p)
    for (size_t c = 0; c < 3; ++c) out.data[p * 3 + c] = img.data[p * ch + (ch >= 3 ? c : 0)];
  return out;
}

Image crop(const Image& src, int x0, int y0, int w, int h) {
  if (x0 < 0 || y0 < 0 || w <= 0 || h <= 0 || x0 + w > src.width || y0 + h > src.height)
    throw Error("crop: rectangle outside the image");
  Image out(w, h, src.channels);
  for (int y = 0; y < h; ++y)
    std::copy_n(&src.data[(size_t(y0 + y) * src.width + x0) * src.channels], size_t(w) * src.channels,
                &out.data[size_t(y) * w * src.channels]);
  return out;
}

void round_to_8bit(Image& img) {
  // Times 1/255, not divided by 255: what OpenImageIO's read does (they differ in the last
  // bit for some codes; tests/io/image_test.cpp compares with a real PNG).
  for (float& v : img.data) v = float(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)) * (1.0f / 255.0f);
}

}  // namespace haha
