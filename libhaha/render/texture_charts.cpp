#include "render/texture_charts.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "core/error.h"

namespace haha {

int64_t TextureCharts::count() const {
  return std::count_if(face.begin(), face.end(), [](int32_t f) { return f >= 0; });
}

namespace {

// Union-find over UV corners: faces sharing a corner are one island.
int32_t root(std::vector<int32_t>& p, int32_t a) {
  while (p[size_t(a)] != a) a = p[size_t(a)] = p[size_t(p[size_t(a)])];
  return a;
}

std::vector<int32_t> uv_islands(const BodyModel& body) {
  const int F = body.num_faces;
  std::vector<int32_t> p(size_t(body.num_uv()));
  std::iota(p.begin(), p.end(), 0);
  for (int f = 0; f < F; ++f)
    for (int k = 1; k < 3; ++k) {
      const int32_t a = root(p, body.ft[size_t(f) * 3]), b = root(p, body.ft[size_t(f) * 3 + k]);
      if (a != b) p[size_t(std::max(a, b))] = std::min(a, b);
    }
  std::vector<int32_t> island(static_cast<size_t>(F));
  for (int f = 0; f < F; ++f) island[size_t(f)] = root(p, body.ft[size_t(f) * 3]);
  return island;
}

// Texel-index coordinates (centres at integers) of UV corner k.
void corner(const BodyModel& b, int f, int k, int W, int H, double& x, double& y) {
  const int32_t t = b.ft[size_t(f) * 3 + k];
  x = double(b.vt[size_t(t) * 2]) * W - 0.5;
  y = (1.0 - double(b.vt[size_t(t) * 2 + 1])) * H - 0.5;
}

}  // namespace

TextureCharts texture_charts(const BodyModel& body, int width, int height) {
  if (width <= 0 || height <= 0)
    fail("texture_charts", "texture size " + std::to_string(width) + "x" + std::to_string(height));
  if (body.ft.size() != size_t(body.num_faces) * 3 || body.vt.empty())
    fail("texture_charts", "the body model has no UV map (vt, ft)");
  for (int32_t t : body.ft)
    if (t < 0 || t >= body.num_uv()) fail("texture_charts", "ft holds an index outside vt");
  TextureCharts c;
  c.width = width;
  c.height = height;
  c.face.assign(size_t(width) * height, -1);
  c.island = uv_islands(body);
  for (int f = 0; f < body.num_faces; ++f) {
    double x[3], y[3];
    for (int k = 0; k < 3; ++k) corner(body, f, k, width, height, x[k], y[k]);
    const double area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    if (!(std::abs(area) > 0)) continue;  // degenerate in UV: holds no texel centre
    const int i0 = std::max(0, int(std::ceil(std::min({x[0], x[1], x[2]}))));
    const int i1 = std::min(width - 1, int(std::floor(std::max({x[0], x[1], x[2]}))));
    const int j0 = std::max(0, int(std::ceil(std::min({y[0], y[1], y[2]}))));
    const int j1 = std::min(height - 1, int(std::floor(std::max({y[0], y[1], y[2]}))));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        bool in = true;
        for (int k = 0; k < 3 && in; ++k) {  // edge functions, signed by the triangle's winding
          const int a = k, b = (k + 1) % 3;
          const double e = (x[b] - x[a]) * (j - y[a]) - (y[b] - y[a]) * (i - x[a]);
          in = e * area >= 0;
        }
        int32_t& slot = c.face[size_t(j) * width + i];
        if (in && slot < 0) slot = f;
      }
  }
  return c;
}

}  // namespace haha
