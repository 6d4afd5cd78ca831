#include "train/texture_fill.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>

#include "core/error.h"

namespace haha {

namespace {

// Texel-index coordinates (centres at integers) of a UV point.
void to_texel(const TextureCharts& c, double u, double v, double& x, double& y) {
  x = u * c.width - 0.5;
  y = (1.0 - v) * c.height - 0.5;
}

// The chart texel of `island` nearest to (x, y) within two texels, or -1.
int64_t nearest_texel(const TextureCharts& c, double x, double y, int32_t island) {
  int64_t best = -1;
  double best_d = 1e30;
  const int ix = int(std::lround(x)), iy = int(std::lround(y));
  for (int j = iy - 2; j <= iy + 2; ++j)
    for (int i = ix - 2; i <= ix + 2; ++i) {
      if (i < 0 || j < 0 || i >= c.width || j >= c.height) continue;
      const int32_t f = c.face[size_t(j) * c.width + i];
      if (f < 0 || c.island[size_t(f)] != island) continue;
      const double d = (i - x) * (i - x) + (j - y) * (j - y);
      if (d < best_d) best_d = d, best = int64_t(j) * c.width + i;
    }
  return best;
}

using Links = std::vector<std::pair<int64_t, int64_t>>;

// Links between the texels along both UV sides of every seam edge.
int64_t seam_links(const BodyModel& b, const TextureCharts& c, Links& links) {
  std::map<std::pair<int32_t, int32_t>, std::pair<int, int>> first;  // 3D edge -> (face, edge slot)
  int64_t added = 0;
  for (int f = 0; f < b.num_faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int32_t va = b.faces[size_t(f) * 3 + k], vb = b.faces[size_t(f) * 3 + (k + 1) % 3];
      const auto key = std::minmax(va, vb);
      auto it = first.find({key.first, key.second});
      if (it == first.end()) {
        first[{key.first, key.second}] = {f, k};
        continue;
      }
      const int g = it->second.first, l = it->second.second;
      // UV corners of the edge's ends (key.first, key.second) on faces f and g.
      auto uv_of = [&](int face, int slot, int32_t vert) {
        const int32_t v0 = b.faces[size_t(face) * 3 + slot];
        return b.ft[size_t(face) * 3 + (v0 == vert ? slot : (slot + 1) % 3)];
      };
      const int32_t f0 = uv_of(f, k, key.first), f1 = uv_of(f, k, key.second);
      const int32_t g0 = uv_of(g, l, key.first), g1 = uv_of(g, l, key.second);
      if (f0 == g0 && f1 == g1) continue;  // not a seam: the grid links this edge's texels
      double fx0, fy0, fx1, fy1, gx0, gy0, gx1, gy1;
      to_texel(c, b.vt[2 * size_t(f0)], b.vt[2 * size_t(f0) + 1], fx0, fy0);
      to_texel(c, b.vt[2 * size_t(f1)], b.vt[2 * size_t(f1) + 1], fx1, fy1);
      to_texel(c, b.vt[2 * size_t(g0)], b.vt[2 * size_t(g0) + 1], gx0, gy0);
      to_texel(c, b.vt[2 * size_t(g1)], b.vt[2 * size_t(g1) + 1], gx1, gy1);
      const double len = std::max(std::hypot(fx1 - fx0, fy1 - fy0), std::hypot(gx1 - gx0, gy1 - gy0));
      const int n = std::max(2, int(std::ceil(len)) + 1);
      int64_t last_a = -1, last_b = -1;
      for (int s = 0; s < n; ++s) {
        const double w = double(s) / double(n - 1);
        const int64_t ta = nearest_texel(c, fx0 + w * (fx1 - fx0), fy0 + w * (fy1 - fy0), c.island[size_t(f)]);
        const int64_t tb = nearest_texel(c, gx0 + w * (gx1 - gx0), gy0 + w * (gy1 - gy0), c.island[size_t(g)]);
        if (ta < 0 || tb < 0 || ta == tb || (ta == last_a && tb == last_b)) continue;
        links.push_back({ta, tb});
        last_a = ta, last_b = tb;
        ++added;
      }
    }
  return added;
}

}  // namespace

TexelGraph texel_graph(const BodyModel& body, const TextureCharts& charts) {
  if (charts.island.size() != size_t(body.num_faces) ||
      charts.face.size() != size_t(charts.width) * size_t(charts.height))
    fail("texel_graph", "the charts were not made from this body model");
  const int W = charts.width, H = charts.height;
  Links links;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int64_t i = int64_t(y) * W + x;
      const int32_t f = charts.face[size_t(i)];
      if (f < 0) continue;
      auto link = [&](int64_t j) {
        const int32_t g = charts.face[size_t(j)];
        if (g >= 0 && charts.island[size_t(g)] == charts.island[size_t(f)]) links.push_back({i, j});
      };
      if (x + 1 < W) link(i + 1);
      if (y + 1 < H) link(i + W);
    }
  TexelGraph g;
  g.seam_links = seam_links(body, charts, links);
  const size_t N = charts.face.size();
  g.offset.assign(N + 1, 0);
  for (auto& [a, b] : links) ++g.offset[size_t(a) + 1], ++g.offset[size_t(b) + 1];
  for (size_t i = 0; i < N; ++i) g.offset[i + 1] += g.offset[i];
  g.neighbor.resize(size_t(g.offset[N]));
  std::vector<int64_t> fill(g.offset.begin(), g.offset.end() - 1);
  for (auto& [a, b] : links) {
    g.neighbor[size_t(fill[size_t(a)]++)] = b;
    g.neighbor[size_t(fill[size_t(b)]++)] = a;
  }
  return g;
}

namespace {

// Breadth-first spread over the graph from the texels with c >= 1/2: each later ring takes
// the mean of its already-reached neighbours. Texels no seed reaches keep their own value.
std::vector<float> spread_from_seen(const TexelGraph& g, const std::vector<float>& c, const std::vector<float>& rgb) {
  const size_t N = c.size();
  std::vector<float> x = rgb;
  std::vector<uint8_t> reached(N, 0);
  std::vector<int64_t> ring, next;
  for (size_t i = 0; i < N; ++i)
    if (g.offset[i + 1] > g.offset[i] && c[i] >= 0.5f) reached[i] = 1, ring.push_back(int64_t(i));
  while (!ring.empty()) {
    next.clear();
    for (int64_t i : ring)
      for (int64_t k = g.offset[size_t(i)]; k < g.offset[size_t(i) + 1]; ++k) {
        const int64_t j = g.neighbor[size_t(k)];
        if (!reached[size_t(j)]) reached[size_t(j)] = 2, next.push_back(j);  // 2: in this ring
      }
    for (int64_t j : next) {  // mean of the neighbours reached before this ring
      float s[3] = {0, 0, 0};
      int n = 0;
      for (int64_t k = g.offset[size_t(j)]; k < g.offset[size_t(j) + 1]; ++k) {
        const int64_t m = g.neighbor[size_t(k)];
        if (reached[size_t(m)] != 1) continue;
        for (int ch = 0; ch < 3; ++ch) s[ch] += x[3 * size_t(m) + ch];
        ++n;
      }
      for (int ch = 0; ch < 3; ++ch) x[3 * size_t(j) + ch] = s[ch] / float(n);
    }
    for (int64_t j : next) reached[size_t(j)] = 1;
    std::swap(ring, next);
  }
  return x;
}

}  // namespace

void dilate_into_gutter(const TextureCharts& charts, const std::vector<float>& confidence, std::vector<float>& rgb) {
  const int W = charts.width, H = charts.height;
  const size_t N = size_t(W) * H;
  if (rgb.size() != 3 * N || (!confidence.empty() && confidence.size() != N))
    fail("texture_fill", "texture, confidence and charts differ in size");
  std::vector<uint8_t> done(N, 0);
  std::vector<int64_t> ring, next;
  for (size_t i = 0; i < N; ++i)
    if (charts.face[i] >= 0) done[i] = 1, ring.push_back(int64_t(i));
  const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
  std::vector<float> value(3);
  while (!ring.empty()) {
    next.clear();
    for (int64_t i : ring)
      for (int d = 0; d < 4; ++d) {
        const int x = int(i % W) + dx[d], y = int(i / W) + dy[d];
        if (x < 0 || y < 0 || x >= W || y >= H) continue;
        const int64_t j = int64_t(y) * W + x;
        if (!done[size_t(j)]) done[size_t(j)] = 2, next.push_back(j);
      }
    for (int64_t j : next) {
      float s[3] = {0, 0, 0};
      int n = 0;
      for (int d = 0; d < 4; ++d) {
        const int x = int(j % W) + dx[d], y = int(j / W) + dy[d];
        if (x < 0 || y < 0 || x >= W || y >= H || done[size_t(y) * W + x] != 1) continue;
        for (int ch = 0; ch < 3; ++ch) s[ch] += rgb[3 * (size_t(y) * W + x) + ch];
        ++n;
      }
      const float c = confidence.empty() ? 0.0f : confidence[size_t(j)];
      for (int ch = 0; ch < 3; ++ch) {
        float& t = rgb[3 * size_t(j) + ch];
        t = c * t + (1 - c) * s[ch] / float(n);
      }
    }
    for (int64_t j : next) done[size_t(j)] = 1;
    std::swap(ring, next);
  }
}

FillReport fill_low_evidence(const BodyModel& body, const TextureCharts& charts, const std::vector<float>& evidence,
                             const FillOptions& opt, std::vector<float>& rgb) {
  const size_t N = charts.face.size();
  if (evidence.size() != N || rgb.size() != 3 * N)
    fail("texture_fill", "texture (" + std::to_string(rgb.size() / 3) + " texels), evidence (" +
                             std::to_string(evidence.size()) + ") and charts (" + std::to_string(N) +
                             ") differ in size");
  if (!(opt.evidence_full > 0)) fail("texture_fill", "evidence_full must be > 0");
  const TexelGraph g = texel_graph(body, charts);
  FillReport r;
  r.seam_links = g.seam_links;
  std::vector<float> c(N);
  for (size_t i = 0; i < N; ++i) {
    c[i] = float(std::min(1.0, double(evidence[i]) / opt.evidence_full));
    if (charts.face[i] < 0) continue;
    ++r.chart_texels;
    r.low_texels += c[i] < 1.0f;
    r.unseen_texels += evidence[i] <= 0.0f;
  }
  std::vector<float> x = spread_from_seen(g, c, rgb);
  constexpr float kData = 4.0f;  // a texel's own colour against its (about 4) links
  for (int it = 0; it < opt.iterations; ++it)
    for (size_t i = 0; i < N; ++i) {
      const int64_t k0 = g.offset[i], k1 = g.offset[i + 1];
      if (k0 == k1) continue;
      float s[3] = {kData * c[i] * rgb[3 * i], kData * c[i] * rgb[3 * i + 1], kData * c[i] * rgb[3 * i + 2]};
      for (int64_t k = k0; k < k1; ++k)
        for (int ch = 0; ch < 3; ++ch) s[ch] += x[3 * size_t(g.neighbor[size_t(k)]) + ch];
      const float den = kData * c[i] + float(k1 - k0);
      for (int ch = 0; ch < 3; ++ch) x[3 * i + ch] = s[ch] / den;
    }
  for (size_t i = 0; i < N; ++i)
    if (charts.face[i] >= 0)
      for (int ch = 0; ch < 3; ++ch) rgb[3 * i + ch] = c[i] * rgb[3 * i + ch] + (1 - c[i]) * x[3 * i + ch];
  dilate_into_gutter(charts, c, rgb);
  return r;
}

}  // namespace haha
