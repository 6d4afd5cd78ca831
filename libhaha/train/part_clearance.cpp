#include "train/part_clearance.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/parallel.h"

namespace haha {

namespace {

BodyPart part_of_joint(int j) {
  switch (j) {
    case 16: case 18: case 20: return BodyPart::LeftArm;   // shoulder, elbow, wrist
    case 17: case 19: case 21: return BodyPart::RightArm;
    case 1: case 4: case 7: case 10: return BodyPart::LeftLeg;  // hip, knee, ankle, foot
    case 2: case 5: case 8: case 11: return BodyPart::RightLeg;
    default: break;
  }
  if (j >= kLeftHandFirst && j < kRightHandFirst) return BodyPart::LeftArm;
  if (j >= kRightHandFirst) return BodyPart::RightArm;
  return BodyPart::Trunk;  // pelvis, spine, neck, collars, head, jaw, eyes
}

// The vertices of one frame bucketed in a uniform grid of cells `cell` wide: a cell's
// vertices are idx[start[c] .. start[c + 1]).
struct VertexGrid {
  float lo[3] = {0, 0, 0}, cell = 1;
  int n[3] = {1, 1, 1};
  std::vector<int32_t> start, idx;

  VertexGrid(const float* p, int count, float cell_size) : cell(cell_size) {
    float hi[3];
    for (int k = 0; k < 3; ++k) lo[k] = hi[k] = count > 0 ? p[k] : 0.0f;
    for (int v = 0; v < count; ++v)
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[3 * size_t(v) + k]), hi[k] = std::max(hi[k], p[3 * size_t(v) + k]);
    // At most 256 cells a side: a body spans a few metres, but a wild fit must not make the
    // grid the allocation.
    for (int k = 0; k < 3; ++k) cell = std::max(cell, (hi[k] - lo[k]) / 255.0f);
    for (int k = 0; k < 3; ++k) n[k] = std::max(1, int((hi[k] - lo[k]) / cell) + 1);
    std::vector<int32_t> of(static_cast<size_t>(count));
    start.assign(size_t(n[0]) * n[1] * n[2] + 1, 0);
    for (int v = 0; v < count; ++v) {
      of[size_t(v)] = cell_of(p + 3 * size_t(v));
      ++start[size_t(of[size_t(v)]) + 1];
    }
    for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
    idx.resize(size_t(count));
    std::vector<int32_t> fill(start.begin(), start.end() - 1);
    for (int v = 0; v < count; ++v) idx[size_t(fill[size_t(of[size_t(v)])]++)] = v;
  }
  int coord(const float* q, int k) const { return std::clamp(int((q[k] - lo[k]) / cell), 0, n[k] - 1); }
  int32_t cell_of(const float* q) const { return (coord(q, 2) * n[1] + coord(q, 1)) * n[0] + coord(q, 0); }
};

// One frame's bound for every vertex, folded into `bound` (which starts at the caps) by the
// minimum. Cells are at least `cell` wide; a vertex whose bound is b looks only as far as 2 b: beyond
// it the bisector bound |d|^2 / (2 d.u) >= |d| / 2 exceeds b.
void fold_frame(const std::vector<BodyPart>& part, const float* p, const float* u, float cell, std::vector<float>& bound) {
  const int V = int(part.size());
  const VertexGrid grid(p, V, cell);
  parallel_for(V, [&](int64_t v) {
    const float* a = p + 3 * v;
    const float* n = u + 3 * v;
    float b = bound[size_t(v)];
    const int rings = int(std::ceil(2 * b / grid.cell));
    const int c[3] = {grid.coord(a, 0), grid.coord(a, 1), grid.coord(a, 2)};
    for (int z = std::max(0, c[2] - rings); z <= std::min(grid.n[2] - 1, c[2] + rings); ++z)
      for (int y = std::max(0, c[1] - rings); y <= std::min(grid.n[1] - 1, c[1] + rings); ++y)
        for (int x = std::max(0, c[0] - rings); x <= std::min(grid.n[0] - 1, c[0] + rings); ++x) {
          const size_t cell_id = size_t((z * grid.n[1] + y) * grid.n[0] + x);
          for (int32_t k = grid.start[cell_id]; k < grid.start[cell_id + 1]; ++k) {
            const int32_t w = grid.idx[size_t(k)];
            const float d[3] = {p[3 * size_t(w)] - a[0], p[3 * size_t(w) + 1] - a[1], p[3 * size_t(w) + 2] - a[2]};
            const float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if (d2 >= 4 * b * b || !parts_kept_apart(part[size_t(w)], part[size_t(v)])) continue;
            const float t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            if (!(t > 0)) continue;  // behind the vertex's tangent plane: never in its way
            b = std::min(b, d2 / (2 * t));
          }
        }
    bound[size_t(v)] = b;
  });
}

}  // namespace

bool parts_kept_apart(BodyPart a, BodyPart b) {
  return a != b && a != BodyPart::Garment && b != BodyPart::Garment;
}

std::vector<BodyPart> body_part_of_vertices(const BodyModel& body) {
  const int V = body.num_body_verts();
  std::vector<BodyPart> out(size_t(body.num_verts), BodyPart::Garment);
  for (int v = 0; v < V; ++v) {
    std::array<float, 5> share{};
    const float* w = body.weights.data() + size_t(v) * kNumJoints;
    for (int j = 0; j < kNumJoints; ++j) share[size_t(part_of_joint(j))] += w[j];
    out[size_t(v)] = BodyPart(std::max_element(share.begin(), share.end()) - share.begin());
  }
  return out;
}

std::vector<float> part_clearance_bounds(const BodyModel& body, const std::vector<std::vector<float>>& posed,
                                         const std::vector<std::vector<float>>& dirs, float cap) {
  std::vector<BodyPart> part = body_part_of_vertices(body);
  part.resize(size_t(body.num_body_verts()));  // the garment's vertices hold nothing and are not held
  std::vector<float> bound(part.size(), cap);
  const float cell = 2 * std::max(cap, 1e-3f);  // a vertex looks one cell around its own
  for (size_t f = 0; f < posed.size() && f < dirs.size(); ++f) fold_frame(part, posed[f].data(), dirs[f].data(), cell, bound);
  for (float& b : bound) b = std::max(0.0f, b);
  return bound;
}

}  // namespace haha
