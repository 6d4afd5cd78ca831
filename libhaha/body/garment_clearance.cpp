#include "body/garment_clearance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>

#include "body/garment.h"
#include "core/math.h"
#include "core/parallel.h"

namespace haha {

namespace {

using V3 = Vec3<double>;

V3 vert(const float* p, int i) { return V3(p[3 * size_t(i)], p[3 * size_t(i) + 1], p[3 * size_t(i) + 2]); }

// Closest point of triangle (a, b, c) to p as barycentric weights (Ericson, Real-Time
// Collision Detection 5.1.5: the Voronoi region of each vertex and edge, else the face).
V3 closest_barycentric(V3 p, V3 a, V3 b, V3 c) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return V3(1, 0, 0);
  const V3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return V3(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return V3(1 - v, v, 0);
  }
  const V3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return V3(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return V3(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return V3(0, 1 - w, w);
  }
  const double den = 1.0 / (va + vb + vc);
  return V3(va * den, vb * den, vc * den);
}

// The garment's faces and its border (edges used by one face only: the waist and the hem).
struct GarmentFaces {
  std::vector<int32_t> faces;                // (F, 3) into the whole mesh's vertices
  std::vector<std::array<bool, 3>> border;   // border[f][k]: the edge opposite corner k
  std::vector<char> border_vertex;           // per vertex of the whole mesh
};

GarmentFaces garment_faces(const BodyModel& body) {
  GarmentFaces g;
  g.faces.assign(body.faces.begin() + 3 * size_t(body.garment_first_face), body.faces.end());
  g.border_vertex.assign(size_t(body.num_verts), 0);
  std::map<std::pair<int, int>, int> uses;
  auto key = [](int a, int b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
  for (size_t f = 0; f + 2 < g.faces.size(); f += 3)
    for (int k = 0; k < 3; ++k) ++uses[key(g.faces[f + (k + 1) % 3], g.faces[f + (k + 2) % 3])];
  for (size_t f = 0; f + 2 < g.faces.size(); f += 3) {
    std::array<bool, 3> b{};
    for (int k = 0; k < 3; ++k) {
      const int u = g.faces[f + (k + 1) % 3], w = g.faces[f + (k + 2) % 3];
      b[size_t(k)] = uses[key(u, w)] == 1;
      if (b[size_t(k)]) g.border_vertex[size_t(u)] = g.border_vertex[size_t(w)] = 1;
    }
    g.border.push_back(b);
  }
  return g;
}

// Area-weighted vertex normals of the posed garment (zero elsewhere): the side of a point
// whose nearest garment point is on an edge or a corner, where one face's normal can lie.
std::vector<V3> vertex_normals(const GarmentFaces& g, const float* verts, int num_verts) {
  std::vector<V3> n(size_t(num_verts), V3(0, 0, 0));
  for (size_t f = 0; f + 2 < g.faces.size(); f += 3) {
    const V3 a = vert(verts, g.faces[f]), b = vert(verts, g.faces[f + 1]), c = vert(verts, g.faces[f + 2]);
    const V3 fn = cross(b - a, c - a);
    for (int k = 0; k < 3; ++k) n[size_t(g.faces[f + k])] = n[size_t(g.faces[f + k])] + fn;
  }
  return n;
}

struct Nearest {
  double signed_distance = 0;  // positive on the outer side
  bool on_border = false;      // the nearest point is on the waist or hem edge
};

Nearest nearest_on_garment(const GarmentFaces& g, const std::vector<V3>& normals, const float* verts, V3 p) {
  Nearest best;
  double best_d2 = INFINITY;
  for (size_t f = 0; f < g.border.size(); ++f) {
    const int32_t* t = &g.faces[3 * f];
    const V3 a = vert(verts, t[0]), b = vert(verts, t[1]), c = vert(verts, t[2]);
    const V3 w = closest_barycentric(p, a, b, c);
    const V3 q = w.x * a + w.y * b + w.z * c;
    const double d2 = dot(p - q, p - q);
    if (d2 >= best_d2) continue;
    best_d2 = d2;
    int zeros = 0, corner = 0;
    bool border = false;
    for (int k = 0; k < 3; ++k) {
      if (w[k] > 0) corner = k;
      if (w[k] <= 0) ++zeros, border |= g.border[f][size_t(k)];
    }
    if (zeros == 2) border = g.border_vertex[size_t(t[corner])] != 0;
    // Inside the face its normal says the side; on an edge or a corner the interpolated
    // vertex normals do (a face's own normal can point either way of a crease).
    const V3 n = zeros == 0 ? cross(b - a, c - a) : w.x * normals[size_t(t[0])] + w.y * normals[size_t(t[1])] + w.z * normals[size_t(t[2])];
    const double nn = std::sqrt(dot(n, n));
    best.signed_distance = nn > 0 ? dot(p - q, n) / nn : 0.0;
    best.on_border = border;
  }
  return best;
}

}  // namespace

std::vector<int> garment_covered_vertices(const BodyModel& body, const float* rest) {
  std::vector<int> out;
  if (!body.has_garment()) return out;
  const GarmentFaces g = garment_faces(body);
  const std::vector<int> source = garment_source_vertices(body);
  const std::vector<V3> normals = vertex_normals(g, rest, body.num_verts);
  std::vector<char> inside(source.size(), 0);
  parallel_for(int64_t(source.size()), [&](int64_t i) {
    const Nearest n = nearest_on_garment(g, normals, rest, vert(rest, source[size_t(i)]));
    inside[size_t(i)] = !n.on_border && n.signed_distance < 0;
  });
  for (size_t i = 0; i < source.size(); ++i)
    if (inside[i]) out.push_back(source[i]);
  return out;
}

GarmentClearance garment_clearance(const BodyModel& body, const std::vector<int>& covered, const float* posed) {
  GarmentClearance c;
  c.covered = int(covered.size());
  if (!body.has_garment() || covered.empty()) return c;
  const GarmentFaces g = garment_faces(body);
  const std::vector<V3> normals = vertex_normals(g, posed, body.num_verts);
  std::vector<double> depth(covered.size(), 0.0);
  parallel_for(int64_t(covered.size()), [&](int64_t i) {
    const Nearest n = nearest_on_garment(g, normals, posed, vert(posed, covered[size_t(i)]));
    depth[size_t(i)] = std::max(0.0, n.signed_distance);
  });
  double sum = 0;
  for (double d : depth)
    if (d > 0) {
      ++c.outside;
      sum += d;
      c.max_depth = std::max(c.max_depth, d);
    }
  c.mean_depth = c.outside > 0 ? sum / c.outside : 0.0;
  return c;
}

}  // namespace haha
