#include "body/garment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "core/error.h"

namespace haha {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Torso and legs: pelvis, hips, spine, knees, ankles, feet (SMPL-X joints 0..11).
bool trunk_or_leg(int j) { return j >= 0 && j <= 11; }

// Cloth hangs from the hips: a knee's, ankle's or foot's weight goes to its leg's hip.
int cloth_joint(int j) {
  switch (j) {
    case 4: case 7: case 10: return 1;  // left knee, ankle, foot -> left hip
    case 5: case 8: case 11: return 2;  // right
    default: return j;
  }
}

double column_angle(int k, int C) { return kPi + 2 * kPi * k / C; }  // seam at the back (-Z)

struct P2 {
  double x, z;
};
double cross(P2 o, P2 a, P2 b) { return (a.x - o.x) * (b.z - o.z) - (a.z - o.z) * (b.x - o.x); }

// Convex hull (counter-clockwise, Andrew's monotone chain) of points in the ground plane.
std::vector<P2> convex_hull(std::vector<P2> p) {
  std::sort(p.begin(), p.end(), [](P2 a, P2 b) { return a.x < b.x || (a.x == b.x && a.z < b.z); });
  if (p.size() < 3) return p;
  std::vector<P2> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  return h;
}

// Distance from the origin along direction d to a convex polygon containing the origin
// (0 when the ray misses it: the origin outside).
double ray_to_polygon(const std::vector<P2>& poly, P2 d) {
  double best = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const P2 a = poly[i], b = poly[(i + 1) % poly.size()];
    const P2 e{b.x - a.x, b.z - a.z};
    const double den = d.x * e.z - d.z * e.x;
    if (std::abs(den) < 1e-12) continue;
    const double t = (a.x * e.z - a.z * e.x) / den;    // along the ray
    const double s = (a.x * d.z - a.z * d.x) / den;    // along the edge
    if (t > 0 && s >= -1e-9 && s <= 1 + 1e-9) best = std::max(best, t);
  }
  return best;
}

// Radii (R x C) of the rings: the convex hull of the body's points within each ring's band,
// widened by the clearance, never shrinking down the garment.
std::vector<double> ring_radii(const BodyModel& body, const std::vector<float>& rest, const std::vector<int>& trunk, double ax,
                               double az, const GarmentShape& s) {
  const int R = s.rings, C = s.columns;
  const double band = std::max(std::abs(s.y_top - s.y_hem) / (R - 1), 0.015);
  std::vector<double> rad(size_t(R) * C, 0.0);
  for (int i = 0; i < R; ++i) {
    const double y = s.y_top + (s.y_hem - s.y_top) * i / (R - 1);
    std::vector<P2> pts;
    for (int v : trunk)
      if (std::abs(rest[3 * size_t(v) + 1] - y) <= band)
        pts.push_back({rest[3 * size_t(v)] - ax, rest[3 * size_t(v) + 2] - az});
    if (pts.size() < 3)
      fail(body.source, "garment: no body at height " + std::to_string(y) + " m (the hem is below the feet?)");
    // The hull widened by the clearance: each point pushed out by it in 16 directions.
    std::vector<P2> wide;
    for (const P2& p : pts)
      for (int q = 0; q < 16; ++q)
        wide.push_back({p.x + s.clearance * std::cos(2 * kPi * q / 16), p.z + s.clearance * std::sin(2 * kPi * q / 16)});
    const std::vector<P2> hull = convex_hull(std::move(wide));
    for (int k = 0; k < C; ++k) {
      const double a = column_angle(k, C);
      double r = ray_to_polygon(hull, {std::sin(a), std::cos(a)});
      if (r <= 0) fail(body.source, "garment: the pelvis axis is outside the body at height " + std::to_string(y) + " m");
      if (i > 0) r = std::max(r, rad[size_t(i - 1) * C + k]);
      rad[size_t(i) * C + k] = r;
    }
  }
  return rad;
}

// Faces of the R x C ring grid (closed around, open at the waist and the hem), each turned
// to face away from the axis.
std::vector<int32_t> loft_faces(const std::vector<float>& verts, int R, int C, double ax, double az) {
  std::vector<int32_t> f;
  auto id = [C](int i, int k) { return int32_t(i * C + (k % C)); };
  auto add = [&](int32_t a, int32_t b, int32_t c) {
    const float* A = &verts[3 * size_t(a)];
    const float* B = &verts[3 * size_t(b)];
    const float* D = &verts[3 * size_t(c)];
    const double e1[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, e2[3] = {D[0] - A[0], D[1] - A[1], D[2] - A[2]};
    const double nx = e1[1] * e2[2] - e1[2] * e2[1], nz = e1[0] * e2[1] - e1[1] * e2[0];
    const double cx = (A[0] + B[0] + D[0]) / 3 - ax, cz = (A[2] + B[2] + D[2]) / 3 - az;
    if (nx * cx + nz * cz < 0) std::swap(b, c);
    f.insert(f.end(), {a, b, c});
  };
  for (int i = 0; i + 1 < R; ++i)
    for (int k = 0; k < C; ++k) {
      add(id(i, k), id(i, k + 1), id(i + 1, k + 1));
      add(id(i, k), id(i + 1, k + 1), id(i + 1, k));
    }
  return f;
}

void expect(bool ok, const char* where, const std::string& what) {
  if (!ok) fail(where, "garment " + what);
}

}  // namespace

// Body vertices mostly driven by the torso and the legs (arms, hands and head left out).
std::vector<int> garment_source_vertices(const BodyModel& body) {
  std::vector<int> out;
  const int V = body.num_body_verts();
  for (int v = 0; v < V; ++v) {
    double s = 0;
    for (int j = 0; j < kNumJoints; ++j)
      if (trunk_or_leg(j)) s += body.weights[size_t(v) * kNumJoints + size_t(j)];
    if (s >= 0.5) out.push_back(v);
  }
  return out;
}

std::vector<float> garment_skin_weights(const BodyModel& body, const std::vector<float>& rest, const std::vector<float>& pts,
                                        const std::vector<int32_t>& faces, double legs_max, int k, int smooth) {
  const std::vector<int> trunk = garment_source_vertices(body);
  if (trunk.empty()) fail(body.source, "garment: the body has no torso or leg vertices to take skin weights from");
  k = std::clamp(k, 1, int(trunk.size()));
  const int N = int(pts.size() / 3);
  std::vector<double> w(size_t(N) * kNumJoints, 0.0);
  std::vector<std::pair<double, int>> d(trunk.size());
  for (int n = 0; n < N; ++n) {
    const float* p = &pts[3 * size_t(n)];
    for (size_t t = 0; t < trunk.size(); ++t) {
      const float* q = &rest[3 * size_t(trunk[t])];
      const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
      d[t] = {dx * dx + dy * dy + dz * dz, trunk[t]};
    }
    std::partial_sort(d.begin(), d.begin() + k, d.end());
    for (int m = 0; m < k; ++m) {
      const double iw = 1.0 / (std::sqrt(d[size_t(m)].first) + 1e-3);
      const float* bw = &body.weights[size_t(d[size_t(m)].second) * kNumJoints];
      for (int j = 0; j < kNumJoints; ++j) w[size_t(n) * kNumJoints + size_t(cloth_joint(j))] += iw * bw[j];
    }
  }
  // Smoothing over the garment's own edges: neighbours pull a vertex halfway to their mean.
  std::vector<std::vector<int>> nb(static_cast<size_t>(N));
  for (size_t f = 0; f + 2 < faces.size(); f += 3)
    for (int c = 0; c < 3; ++c) {
      nb[size_t(faces[f + c])].push_back(faces[f + (c + 1) % 3]);
      nb[size_t(faces[f + (c + 1) % 3])].push_back(faces[f + c]);
    }
  for (int n = 0; n < N; ++n) {
    double s = 0;
    for (int j = 0; j < kNumJoints; ++j) s += w[size_t(n) * kNumJoints + j];
    for (int j = 0; j < kNumJoints; ++j) w[size_t(n) * kNumJoints + j] /= s;
  }
  for (int it = 0; it < smooth; ++it) {
    std::vector<double> next = w;
    for (int n = 0; n < N; ++n) {
      if (nb[size_t(n)].empty()) continue;
      for (int j = 0; j < kNumJoints; ++j) {
        double m = 0;
        for (int u : nb[size_t(n)]) m += w[size_t(u) * kNumJoints + j];
        next[size_t(n) * kNumJoints + j] = 0.5 * w[size_t(n) * kNumJoints + j] + 0.5 * m / double(nb[size_t(n)].size());
      }
    }
    w.swap(next);
  }
  // Cloth hangs from the waist and the legs push it: the legs' share grows down the garment
  // from nothing at its top to legs_max at its hem (the rigger's gradient), split between
  // the two legs as diffused; the rest is the torso's diffused share (the pelvis where the
  // torso has none).
  double y_top = -INFINITY, y_hem = INFINITY;
  for (int n = 0; n < N; ++n) {
    y_top = std::max(y_top, double(pts[3 * size_t(n) + 1]));
    y_hem = std::min(y_hem, double(pts[3 * size_t(n) + 1]));
  }
  for (int n = 0; n < N; ++n) {
    double* row = &w[size_t(n) * kNumJoints];
    const double t = y_top > y_hem ? (y_top - pts[3 * size_t(n) + 1]) / (y_top - y_hem) : 1.0;
    const double legs = row[1] + row[2], torso = 1 - legs, share = legs_max * t;
    const double left = legs > 1e-9 ? row[1] / legs : (pts[3 * size_t(n)] >= 0 ? 1.0 : 0.0);
    for (int j = 0; j < kNumJoints; ++j) row[j] = torso > 1e-9 ? row[j] * (1 - share) / torso : 0.0;
    if (torso <= 1e-9) row[0] = 1 - share;
    row[1] = share * left, row[2] = share * (1 - left);
  }
  // The four largest, normalised.
  std::vector<float> out(size_t(N) * kNumJoints, 0.0f);
  for (int n = 0; n < N; ++n) {
    std::array<int, kNumJoints> order{};
    for (int j = 0; j < kNumJoints; ++j) order[size_t(j)] = j;
    const double* row = &w[size_t(n) * kNumJoints];
    std::partial_sort(order.begin(), order.begin() + 4, order.end(), [row](int a, int b) { return row[a] > row[b]; });
    double s = 0;
    for (int m = 0; m < 4; ++m) s += row[order[size_t(m)]];
    for (int m = 0; m < 4; ++m) out[size_t(n) * kNumJoints + size_t(order[size_t(m)])] = float(row[order[size_t(m)]] / s);
  }
  return out;
}

Garment build_garment(const BodyModel& body, const std::vector<float>& rest, const std::vector<float>& joints,
                      const GarmentShape& s) {
  if (!(s.y_top > s.y_hem) || s.rings < 2 || s.columns < 8 || !(s.chart > 0 && s.chart <= 0.5f))
    fail(body.source, "garment: degenerate shape (waist above the hem, >= 2 rings, >= 8 columns, chart in (0, 0.5])");
  const double ax = joints[0], az = joints[2];  // the pelvis' vertical axis
  const std::vector<double> rad = ring_radii(body, rest, garment_source_vertices(body), ax, az, s);
  const int R = s.rings, C = s.columns;
  Garment g;
  g.chart = s.chart;
  for (int i = 0; i < R; ++i) {
    const double y = s.y_top + (s.y_hem - s.y_top) * i / (R - 1);
    for (int k = 0; k < C; ++k) {
      const double a = column_angle(k, C), r = rad[size_t(i) * C + k];
      g.verts.insert(g.verts.end(), {float(ax + r * std::sin(a)), float(y), float(az + r * std::cos(a))});
    }
  }
  g.faces = loft_faces(g.verts, R, C, ax, az);
  // The chart: rings across (waist on the left), columns up, C + 1 columns for the seam; a
  // margin of 2% of the chart keeps bilinear lookups off the body's charts.
  const double pad = 0.02;
  for (int i = 0; i < R; ++i)
    for (int k = 0; k <= C; ++k) {
      const double u = (1.0 - s.chart) + s.chart * (pad + (1 - 2 * pad) * i / (R - 1));
      g.vt.insert(g.vt.end(), {float(u), float(pad + (1 - 2 * pad) * k / C)});
    }
  for (size_t f = 0; f < g.faces.size(); ++f) {
    // The UV of a corner: its ring and column, the seam's vertices taking column C when
    // their face wraps around.
    const int v = g.faces[f], i = v / C, k = v % C;
    const size_t f0 = f - f % 3;
    bool wraps = false;
    for (int c = 0; c < 3; ++c) wraps |= (g.faces[f0 + size_t(c)] % C) == C - 1;
    g.ft.push_back(int32_t(i * (C + 1) + ((wraps && k == 0) ? C : k)));
  }
  g.weights = garment_skin_weights(body, rest, g.verts, g.faces, s.legs);
  return g;
}

BodyModel append_garment(const BodyModel& body, const Garment& g) {
  if (body.has_garment()) fail(body.source, "garment: the body already has one");
  validate_garment(g, body.source.c_str());
  const int V = body.num_verts, G = g.num_verts(), T = body.num_uv();
  const size_t S = body.shapedirs.size() / (size_t(std::max(1, V)) * 3);
  BodyModel out = body;
  out.num_verts = V + G;
  out.num_faces = body.num_faces + g.num_faces();
  out.v_template.insert(out.v_template.end(), g.verts.begin(), g.verts.end());
  for (int32_t i : g.faces) out.faces.push_back(i + V);
  if (!body.j_regressor.empty()) {
    out.j_regressor.assign(size_t(kNumJoints) * (V + G), 0.0f);
    for (int j = 0; j < kNumJoints; ++j)
      std::copy_n(&body.j_regressor[size_t(j) * V], V, &out.j_regressor[size_t(j) * (V + G)]);
  }
  out.weights.insert(out.weights.end(), g.weights.begin(), g.weights.end());
  out.shapedirs.resize(body.shapedirs.size() + size_t(G) * 3 * S, 0.0f);
  if (!body.posedirs.empty()) out.posedirs.resize(body.posedirs.size() + size_t(G) * 3 * kNumPoseFeatures, 0.0f);
  if (!body.rest_offsets.empty()) out.rest_offsets.resize(size_t(V + G) * 3, 0.0f);
  for (size_t i = 0; i < out.vt.size(); i += 2) out.vt[i] *= 1.0f - g.chart;
  out.vt.insert(out.vt.end(), g.vt.begin(), g.vt.end());
  for (int32_t i : g.ft) out.ft.push_back(i + T);
  out.garment_first_vert = V;
  out.garment_first_face = body.num_faces;
  out.garment_first_uv = T;
  out.garment_chart = g.chart;
  return out;
}

Garment garment_of(const BodyModel& b) {
  Garment g;
  if (!b.has_garment()) return g;
  const int V = b.garment_first_vert, F = b.garment_first_face, T = b.garment_first_uv;
  g.chart = b.garment_chart;
  g.verts.assign(b.v_template.begin() + 3 * size_t(V), b.v_template.end());
  for (size_t i = 3 * size_t(F); i < b.faces.size(); ++i) g.faces.push_back(b.faces[i] - V);
  g.weights.assign(b.weights.begin() + size_t(V) * kNumJoints, b.weights.end());
  g.vt.assign(b.vt.begin() + 2 * size_t(T), b.vt.end());
  for (size_t i = 3 * size_t(F); i < b.ft.size(); ++i) g.ft.push_back(b.ft[i] - T);
  return g;
}

void validate_garment(const Garment& g, const char* where) {
  const size_t G = g.verts.size() / 3, Fg = g.faces.size() / 3, Tg = g.vt.size() / 2;
  expect(G > 0 && g.verts.size() == 3 * G, where, "vertices: not (G, 3) with G > 0");
  expect(Fg > 0 && g.faces.size() == 3 * Fg, where, "faces: not (F, 3) with F > 0");
  expect(g.weights.size() == G * kNumJoints, where, "weights: not (G, 55)");
  expect(Tg > 0 && g.vt.size() == 2 * Tg, where, "uv: not (T, 2) with T > 0");
  expect(g.ft.size() == g.faces.size(), where, "uv faces: not one per face corner");
  expect(g.chart > 0 && g.chart <= 0.5f, where, "chart: not in (0, 0.5]");
  for (int32_t i : g.faces) expect(i >= 0 && size_t(i) < G, where, "faces: vertex index out of range");
  for (int32_t i : g.ft) expect(i >= 0 && size_t(i) < Tg, where, "uv faces: index out of range");
  for (float x : g.verts) expect(std::isfinite(x), where, "vertices: non-finite value");
  for (float x : g.vt) expect(std::isfinite(x) && x >= 0 && x <= 1, where, "uv: outside [0, 1]");
  for (size_t v = 0; v < G; ++v) {
    double s = 0;
    for (int j = 0; j < kNumJoints; ++j) {
      const float w = g.weights[v * kNumJoints + size_t(j)];
      expect(std::isfinite(w) && w >= 0, where, "weights: negative or non-finite");
      s += w;
    }
    expect(std::abs(s - 1) < 1e-3, where, "weights: a vertex's weights do not sum to 1");
  }
}

}  // namespace haha
