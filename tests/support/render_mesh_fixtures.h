// Test and benchmark meshes for the mesh rasterizer: closed, consistently outward-oriented
// spheres/ellipsoids with per-corner UVs (a longitude seam and pole fans, like SMPL-X's
// vt/ft), a body-like union of ellipsoids, and a look-at camera.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/math.h"
#include "core/camera.h"

namespace haha::fixtures {

struct TestMesh {
  std::vector<float> verts;    // (V, 3)
  std::vector<int32_t> faces;  // (F, 3)
  std::vector<float> uv;       // (T, 2)
  std::vector<int32_t> ft;     // (F, 3)
  int num_verts() const { return int(verts.size() / 3); }
  int num_faces() const { return int(faces.size() / 3); }
  int num_uv() const { return int(uv.size() / 2); }
};

// Flips faces whose normal points towards `inside` (valid for star-shaped parts).
inline void orient_outward(TestMesh& m, int first_face, Vec3d inside) {
  for (int f = first_face; f < m.num_faces(); ++f) {
    Vec3d v[3];
    for (int i = 0; i < 3; ++i) v[i] = Vec3d(Vec3f::load(&m.verts[3 * m.faces[3 * f + i]]));
    const Vec3d n = cross(v[1] - v[0], v[2] - v[0]);
    if (dot(n, (v[0] + v[1] + v[2]) / 3.0 - inside) < 0) {
      std::swap(m.faces[3 * f + 1], m.faces[3 * f + 2]);
      std::swap(m.ft[3 * f + 1], m.ft[3 * f + 2]);
    }
  }
}

// Appends a closed UV-sphere ellipsoid (rings >= 2, segments >= 3): 2 s (r - 1) faces. Its
// UV grid is mapped into the chart rectangle [u0, u1] x [v0, v1]; the longitude seam and the
// poles get separate UV vertices per corner.
inline void add_ellipsoid(TestMesh& m, Vec3d c, Vec3d radii, int rings, int segments, double u0 = 0, double v0 = 0,
                          double u1 = 1, double v1 = 1) {
  const double pi = 3.14159265358979323846;
  const int base = m.num_verts(), uvbase = m.num_uv(), first_face = m.num_faces();
  auto vid = [&](int r, int s) {  // r in [0, rings]: 0 = north pole
    if (r == 0) return base;
    if (r == rings) return base + 1 + (rings - 1) * segments;
    return base + 1 + (r - 1) * segments + (s % segments);
  };
  auto push = [&](Vec3d p) {
    m.verts.push_back(float(p.x));
    m.verts.push_back(float(p.y));
    m.verts.push_back(float(p.z));
  };
  push(c + Vec3d(0, radii.y, 0));
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double th = pi * r / rings, ph = 2 * pi * s / segments;
      push(c + Vec3d(radii.x * std::sin(th) * std::cos(ph), radii.y * std::cos(th), radii.z * std::sin(th) * std::sin(ph)));
    }
  push(c - Vec3d(0, radii.y, 0));
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s <= segments; ++s) {
      m.uv.push_back(float(u0 + (u1 - u0) * s / segments));
      m.uv.push_back(float(v1 - (v1 - v0) * r / rings));
    }
  auto uid = [&](int r, int s) { return uvbase + r * (segments + 1) + s; };
  auto tri = [&](int ra, int sa, int rb, int sb, int rc, int sc) {
    m.faces.insert(m.faces.end(), {vid(ra, sa), vid(rb, sb), vid(rc, sc)});
    m.ft.insert(m.ft.end(), {uid(ra, sa), uid(rb, sb), uid(rc, sc)});
  };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      if (r > 0) tri(r, s, r, s + 1, r + 1, s);
      if (r < rings - 1) tri(r, s + 1, r + 1, s + 1, r + 1, s);
    }
  orient_outward(m, first_face, c);
}

// Icosphere: subdivided icosahedron, closed and outward-oriented, 20 * 4^level faces; UVs
// are a per-corner planar projection (fine for raster tests).
inline TestMesh icosphere(int level, Vec3d c = Vec3d(0, 0, 0), double radius = 1) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                          {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<int> f = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6,
                        7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
  for (auto& p : v) p = p / norm(p);
  for (int l = 0; l < level; ++l) {
    std::vector<int> nf;
    std::vector<std::pair<std::pair<int, int>, int>> mids;
    auto mid = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      for (auto& e : mids)
        if (e.first == key) return e.second;
      Vec3d p = v[a] + v[b];
      v.push_back(p / norm(p));
      mids.push_back({key, int(v.size()) - 1});
      return int(v.size()) - 1;
    };
    for (size_t i = 0; i < f.size(); i += 3) {
      const int a = f[i], b = f[i + 1], cc = f[i + 2];
      const int ab = mid(a, b), bc = mid(b, cc), ca = mid(cc, a);
      nf.insert(nf.end(), {a, ab, ca, b, bc, ab, cc, ca, bc, ab, bc, ca});
    }
    f = nf;
  }
  TestMesh m;
  for (auto& p : v) {
    const Vec3d q = c + radius * p;
    m.verts.insert(m.verts.end(), {float(q.x), float(q.y), float(q.z)});
  }
  for (size_t i = 0; i < f.size(); ++i) {
    m.faces.push_back(f[i]);
    m.ft.push_back(int(i));
    m.uv.push_back(float(0.5 + 0.45 * v[f[i]].x));
    m.uv.push_back(float(0.5 + 0.45 * v[f[i]].y));
  }
  orient_outward(m, 0, c);
  return m;
}

// A standing "body" (y up, metres, about 1.7 m tall, centred at the origin in x/z, feet at
// y = -0.85): torso, head, two arms, two legs as ellipsoids, each with its own UV chart in a
// 3 x 2 atlas. segments = 48, rings = 36 gives 6 x 3360 = 20160 faces.
inline TestMesh body_like_mesh(int rings = 36, int segments = 48) {
  TestMesh m;
  struct Part { Vec3d c, r; };
  const Part parts[6] = {{{0, 0.15, 0}, {0.17, 0.32, 0.11}},     {{0, 0.65, 0}, {0.10, 0.13, 0.11}},
                         {{-0.33, 0.2, 0}, {0.06, 0.33, 0.06}},  {{0.33, 0.2, 0}, {0.06, 0.33, 0.06}},
                         {{-0.09, -0.5, 0}, {0.08, 0.37, 0.08}}, {{0.09, -0.5, 0}, {0.08, 0.37, 0.08}}};
  for (int i = 0; i < 6; ++i) {
    const double u0 = (i % 3) / 3.0, v0 = (i / 3) / 2.0;
    add_ellipsoid(m, parts[i].c, parts[i].r, rings, segments, u0 + 0.01, v0 + 0.01, u0 + 1 / 3.0 - 0.01, v0 + 0.49);
  }
  return m;
}

// OpenCV look-at camera (x right, y down, z forward) at `eye` looking at `target`, world up +y.
inline Camera look_at_camera(int w, int h, double f, Vec3d eye, Vec3d target, Vec3d up = Vec3d(0, 1, 0)) {
  const Vec3d fwd = (target - eye) / norm(target - eye);
  Vec3d right = cross(fwd, up);
  right = right / norm(right);
  const Vec3d down = cross(fwd, right);
  Camera cam;
  cam.width = w;
  cam.height = h;
  cam.fx = cam.fy = float(f);
  cam.cx = float(w / 2.0);
  cam.cy = float(h / 2.0);
  const Vec3d rows[3] = {right, down, fwd};
  for (int i = 0; i < 3; ++i) {
    cam.R.a[i][0] = float(rows[i].x);
    cam.R.a[i][1] = float(rows[i].y);
    cam.R.a[i][2] = float(rows[i].z);
    cam.t[i] = float(-dot(rows[i], eye));
  }
  return cam;
}

}  // namespace haha::fixtures
