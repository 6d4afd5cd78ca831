#include "train/knn.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/parallel.h"

namespace haha {
namespace {

struct Grid {
  float lo[3] = {0, 0, 0};
  float h = 1;  // cell edge
  int dim[3] = {1, 1, 1};
  std::vector<int64_t> start;  // cell -> first slot in `order`, size cells + 1
  std::vector<int32_t> order;  // point indices sorted by cell

  int cell_coord(float v, int a) const {
    const int c = int(std::floor((v - lo[a]) / h));
    return std::clamp(c, 0, dim[a] - 1);
  }
  int64_t cell_id(int cx, int cy, int cz) const { return (int64_t(cz) * dim[1] + cy) * dim[0] + cx; }
};

void build_grid(const float* p, int64_t n, Grid& g) {
  float hi[3];
  for (int a = 0; a < 3; ++a) g.lo[a] = hi[a] = p[a];
  for (int64_t i = 1; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = std::min(g.lo[a], p[3 * i + a]);
      hi[a] = std::max(hi[a], p[3 * i + a]);
    }
  const double ext_max = std::max({double(hi[0]) - g.lo[0], double(hi[1]) - g.lo[1], double(hi[2]) - g.lo[2]});
  if (!(ext_max > 0.0)) {  // all points equal: one cell
    g.h = 1;
    g.dim[0] = g.dim[1] = g.dim[2] = 1;
  } else {
    // About one point per cell of the bounding box (flat axes count as a sliver), then
    // finer while occupied cells stay crowded: surface samples (a body) fill only a thin
    // shell of the box. The cell count stays below 16 n.
    double vol = 1.0;
    for (int a = 0; a < 3; ++a) vol *= std::max(double(hi[a]) - g.lo[a], 1e-3 * ext_max);
    double h = std::cbrt(vol / double(n));
    const double max_cells = 16.0 * double(n) + 64.0;
    for (int iter = 0;; ++iter) {
      double cells = 1.0;
      for (int a = 0; a < 3; ++a) cells *= std::floor((double(hi[a]) - g.lo[a]) / h) + 1.0;
      if (iter > 0 && cells > max_cells) {
        h *= 2.0;  // the previous size was the finest allowed
        break;
      }
      if (iter == 6) break;
      // occupancy of the current size
      std::vector<int64_t> ids(static_cast<size_t>(n));
      int dim[3];
      for (int a = 0; a < 3; ++a) dim[a] = int(std::floor((double(hi[a]) - g.lo[a]) / h)) + 1;
      for (int64_t i = 0; i < n; ++i) {
        int c[3];
        for (int a = 0; a < 3; ++a) c[a] = std::min(dim[a] - 1, int((p[3 * i + a] - g.lo[a]) / h));
        ids[size_t(i)] = (int64_t(c[2]) * dim[1] + c[1]) * dim[0] + c[0];
      }
      std::sort(ids.begin(), ids.end());
      const double occupied = double(std::unique(ids.begin(), ids.end()) - ids.begin());
      if (double(n) / occupied <= 4.0) break;
      h *= 0.5;
    }
    g.h = float(h);
    for (int a = 0; a < 3; ++a) g.dim[a] = int(std::floor((double(hi[a]) - g.lo[a]) / h)) + 1;
  }
  const int64_t cells = int64_t(g.dim[0]) * g.dim[1] * g.dim[2];
  std::vector<int64_t> cell_of(static_cast<size_t>(n));
  g.start.assign(size_t(cells + 1), 0);
  for (int64_t i = 0; i < n; ++i) {
    const int64_t c = g.cell_id(g.cell_coord(p[3 * i], 0), g.cell_coord(p[3 * i + 1], 1), g.cell_coord(p[3 * i + 2], 2));
    cell_of[size_t(i)] = c;
    ++g.start[size_t(c + 1)];
  }
  for (int64_t c = 0; c < cells; ++c) g.start[size_t(c + 1)] += g.start[size_t(c)];
  g.order.resize(size_t(n));
  std::vector<int64_t> fill(g.start.begin(), g.start.end() - 1);
  for (int64_t i = 0; i < n; ++i) g.order[size_t(fill[size_t(cell_of[size_t(i)])]++)] = int32_t(i);
}

// Sorted (distance, index) list of the best k so far.
struct Best {
  int k = 0, count = 0;
  float* d2;
  int32_t* idx;
  void offer(float d, int32_t j) {
    if (count == k && !(d < d2[k - 1] || (d == d2[k - 1] && j < idx[k - 1]))) return;
    int pos = count < k ? count++ : k - 1;
    while (pos > 0 && (d < d2[pos - 1] || (d == d2[pos - 1] && j < idx[pos - 1]))) {
      d2[pos] = d2[pos - 1];
      idx[pos] = idx[pos - 1];
      --pos;
    }
    d2[pos] = d;
    idx[pos] = j;
  }
};

}  // namespace

void knn_search(const float* points, int64_t n, int k, int32_t* out_idx, float* out_d2) {
  if (n <= 0 || k <= 0) return;
  Grid g;
  build_grid(points, n, g);
  const int max_ring = std::max({g.dim[0], g.dim[1], g.dim[2]});
  const int kk = int(std::min<int64_t>(k, n - 1));
  parallel_for_dynamic((n + 255) / 256, [&](int64_t block) {
    std::vector<float> d2buf(size_t(std::max(kk, 1)));
    for (int64_t i = block * 256; i < std::min(n, (block + 1) * 256); ++i) {
      int32_t* row = out_idx + i * k;
      Best best{kk, 0, d2buf.data(), row};
      const float q[3] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
      int c[3];
      double slack = std::numeric_limits<double>::infinity();  // distance from q to its cell's faces
      for (int a = 0; a < 3; ++a) {
        c[a] = g.cell_coord(q[a], a);
        const double lo = g.lo[a] + double(c[a]) * g.h;
        slack = std::min({slack, double(q[a]) - lo, lo + g.h - double(q[a])});
      }
      slack = std::max(slack, 0.0);
      for (int r = 0; kk > 0 && r <= max_ring; ++r) {
        for (int z = c[2] - r; z <= c[2] + r; ++z) {
          if (z < 0 || z >= g.dim[2]) continue;
          for (int y = c[1] - r; y <= c[1] + r; ++y) {
            if (y < 0 || y >= g.dim[1]) continue;
            const bool face = std::abs(z - c[2]) == r || std::abs(y - c[1]) == r;
            for (int x = c[0] - r; x <= c[0] + r; x += (face || r == 0) ? 1 : 2 * r) {
              if (x < 0 || x >= g.dim[0]) continue;
              const int64_t cell = g.cell_id(x, y, z);
              for (int64_t s = g.start[size_t(cell)]; s < g.start[size_t(cell + 1)]; ++s) {
                const int32_t j = g.order[size_t(s)];
                if (j == i) continue;
                const float dx = points[3 * j] - q[0], dy = points[3 * j + 1] - q[1], dz = points[3 * j + 2] - q[2];
                best.offer(dx * dx + dy * dy + dz * dz, j);
              }
            }
          }
        }
        // Every unvisited cell lies at least r*h + slack away (less a rounding margin).
        if (best.count == kk) {
          const double bound = std::max(0.0, double(r) * g.h + slack - 1e-5 * g.h);
          if (double(d2buf[size_t(kk - 1)]) < bound * bound) break;
        }
      }
      for (int t = kk; t < k; ++t) row[t] = -1;
      if (out_d2)
        for (int t = 0; t < k; ++t)
          out_d2[i * k + t] = t < kk ? d2buf[size_t(t)] : std::numeric_limits<float>::infinity();
    }
  });
}

void knn_sets(const float* points, int64_t n, int K, int32_t* out_idx) {
  if (n <= 0 || K <= 0) return;
  std::vector<int32_t> others(size_t(n) * size_t(std::max(K - 1, 1)));
  if (K > 1) knn_search(points, n, K - 1, others.data());
  for (int64_t i = 0; i < n; ++i) {
    out_idx[i * K] = int32_t(i);
    for (int t = 1; t < K; ++t) out_idx[i * K + t] = others[size_t(i * (K - 1) + t - 1)];
  }
}

}  // namespace haha
