#include "fit/fit_video_crop.h"

#include <algorithm>
#include <cmath>

namespace haha {

CropBox mask_box(const Image& mask, float threshold) {
  int x0 = mask.width, y0 = mask.height, x1 = -1, y1 = -1;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y, 0) > threshold) {
        x0 = std::min(x0, x), x1 = std::max(x1, x);
        y0 = std::min(y0, y), y1 = std::max(y1, y);
      }
  if (x1 < 0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

CropBox projected_box(const Camera& cam, const float* verts, int n) {
  double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
  for (int i = 0; i < n; ++i) {
    const Vec3<float> xc = cam.to_camera({verts[3 * i], verts[3 * i + 1], verts[3 * i + 2]});
    if (!(xc.z > cam.near_plane)) continue;
    const Vec2<float> p = cam.project(xc);
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    x0 = std::min(x0, double(p.x)), x1 = std::max(x1, double(p.x));
    y0 = std::min(y0, double(p.y)), y1 = std::max(y1, double(p.y));
  }
  // Pixels touched by [x0, x1] x [y0, y1] (pixel i covers [i, i + 1)), within the frame.
  const int a = int(std::max(0.0, std::floor(x0))), b = int(std::min(double(cam.width), std::floor(x1) + 1));
  const int c = int(std::max(0.0, std::floor(y0))), d = int(std::min(double(cam.height), std::floor(y1) + 1));
  if (x1 < x0 || b <= a || d <= c) return {};
  return {a, c, b - a, d - c};
}

CropBox box_union(const CropBox& a, const CropBox& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  const int x0 = std::min(a.x0, b.x0), y0 = std::min(a.y0, b.y0);
  const int x1 = std::max(a.x0 + a.w, b.x0 + b.w), y1 = std::max(a.y0 + a.h, b.y0 + b.h);
  return {x0, y0, x1 - x0, y1 - y0};
}

namespace {

// [a, b) grown to an even length inside [0, n) where possible: one pixel more at the end,
// else at the start.
void make_even(int& a, int& b, int n) {
  if ((b - a) % 2 == 0) return;
  if (b < n) ++b;
  else if (a > 0) --a;
}

}  // namespace

CropBox dataset_crop(const CropBox& person, int width, int height, const CropOptions& opt) {
  if (person.empty()) return {0, 0, width, height};
  const int m = std::max(opt.min_margin, int(std::lround(opt.margin * std::max(person.w, person.h))));
  int x0 = std::max(0, person.x0 - m), x1 = std::min(width, person.x0 + person.w + m);
  int y0 = std::max(0, person.y0 - m), y1 = std::min(height, person.y0 + person.h + m);
  if (x1 <= x0 || y1 <= y0) return {0, 0, width, height};  // the box lies outside the frame
  make_even(x0, x1, width);
  make_even(y0, y1, height);
  return {x0, y0, x1 - x0, y1 - y0};
}

Camera crop_camera(const Camera& cam, const CropBox& box) {
  Camera c = cam;
  c.width = box.w;
  c.height = box.h;
  c.cx -= float(box.x0);
  c.cy -= float(box.y0);
  return c;
}

}  // namespace haha
