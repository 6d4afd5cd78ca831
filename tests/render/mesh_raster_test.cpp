// Mesh rasterizer forward: agreement with brute-force references, watertightness, the fill
// rule at exact shared edges, perspective-correct barycentrics, and the hard cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "support/render_mesh_fixtures.h"
#include "render/mesh_raster.h"

using namespace haha;
using haha::fixtures::TestMesh;

namespace {

MeshView view(const TestMesh& m) { return {m.verts.data(), m.num_verts(), m.faces.data(), m.num_faces()}; }

void add_triangle(TestMesh& m, Vec3d a, Vec3d b, Vec3d c) {
  const int base = m.num_verts();
  for (Vec3d p : {a, b, c}) m.verts.insert(m.verts.end(), {float(p.x), float(p.y), float(p.z)});
  m.faces.insert(m.faces.end(), {base, base + 1, base + 2});
  m.ft.insert(m.ft.end(), {0, 0, 0});
  if (m.uv.empty()) m.uv = {0.5f, 0.5f};
}

void append(TestMesh& m, const TestMesh& o) {
  const int base = m.num_verts(), ubase = m.num_uv();
  m.verts.insert(m.verts.end(), o.verts.begin(), o.verts.end());
  m.uv.insert(m.uv.end(), o.uv.begin(), o.uv.end());
  for (int i : o.faces) m.faces.push_back(base + i);
  for (int i : o.ft) m.ft.push_back(ubase + i);
}

// Camera-space vertex of the float camera, in double.
Vec3d cam_vertex(const Camera& cam, const TestMesh& m, int v) {
  const CameraT<double> c = cam.cast<double>();
  return c.to_camera(Vec3d(Vec3f::load(&m.verts[3 * v])));
}

// Independent double reference of one pixel: for every triangle, the ray/plane hit by
// Cramer's rule (p = z d = sum b_i v_i, sum b_i = 1), kept when b >= 0 and near <= z <= far.
struct RefHit {
  int tri = -1;
  double z = INFINITY, b[3] = {0, 0, 0};
  bool ambiguous = false;
  std::vector<int> candidates;  // triangles that might legitimately win under rounding
};

RefHit reference_pixel(const Camera& cam, const TestMesh& m, int x, int y, double tol) {
  const CameraT<double> c = cam.cast<double>();
  const Vec3d d = pixel_ray(c, x, y);
  RefHit best;
  struct Hit { int f; double z, bmin; double b[3]; };
  std::vector<Hit> hits;
  for (int f = 0; f < m.num_faces(); ++f) {
    Vec3d v[3];
    for (int i = 0; i < 3; ++i) v[i] = cam_vertex(cam, m, m.faces[3 * f + i]);
    // Solve [v0 - v2, v1 - v2, -d] [b0 b1 z]^T = -v2.
    const Vec3d a0 = v[0] - v[2], a1 = v[1] - v[2], a2 = -d, rhs = -v[2];
    const double det = dot(a0, cross(a1, a2));
    if (std::fabs(det) < 1e-14) continue;
    const double b0 = dot(rhs, cross(a1, a2)) / det, b1 = dot(a0, cross(rhs, a2)) / det,
                 z = dot(a0, cross(a1, rhs)) / det;
    const double b2 = 1 - b0 - b1;
    const double bmin = std::min({b0, b1, b2});
    // Normalise the inside margin by the triangle's size in pixels so tol is ~ pixels.
    if (bmin < -tol || z < cam.near_plane * (1 - tol) || z > cam.far_plane * (1 + tol)) continue;
    hits.push_back({f, z, bmin, {b0, b1, b2}});
  }
  for (const Hit& h : hits)
    if (h.bmin >= 0 && h.z >= cam.near_plane && h.z <= cam.far_plane && h.z < best.z) {
      best.tri = h.f;
      best.z = h.z;
      std::copy(h.b, h.b + 3, best.b);
    }
  for (const Hit& h : hits) {
    const bool edge = h.bmin < tol || std::fabs(h.z - cam.near_plane) < tol * cam.near_plane;
    const bool near_tie = std::fabs(h.z - best.z) <= tol * best.z;
    if (h.f != best.tri && (edge ? h.z <= best.z * (1 + tol) : near_tie)) best.ambiguous = true;
    if (h.f == best.tri && edge) best.ambiguous = true;
    if (h.z <= best.z * (1 + tol) || best.tri < 0) best.candidates.push_back(h.f);
  }
  return best;
}

// The rasterizer's own coverage rule evaluated for every triangle at every pixel (no tiles,
// no bounding boxes): the winning triangle is the nearest, lowest index on ties.
std::vector<int> exact_rule_brute_force(const Camera& cam, const TestMesh& m) {
  std::vector<TriSetup> setups(m.num_faces());
  for (int f = 0; f < m.num_faces(); ++f) {
    Vec3f v[3];
    for (int i = 0; i < 3; ++i) v[i] = cam.to_camera(Vec3f::load(&m.verts[3 * m.faces[3 * f + i]]));
    if (!setup_triangle(cam, v, &setups[f])) setups[f].det = 0;  // mark skipped
  }
  std::vector<int> ids(size_t(cam.width) * cam.height, -1);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      float best = INFINITY;
      const Vec3f d = pixel_ray(cam, x, y);
      for (int f = 0; f < m.num_faces(); ++f) {
        float z;
        if (setups[f].det > 0 && tri_covers(setups[f], d, cam.near_plane, cam.far_plane, &z) && z < best) {
          best = z;
          ids[size_t(y) * cam.width + x] = f;
        }
      }
    }
  return ids;
}

// A scene with overlapping closed meshes, interpenetration, a triangle crossing the near
// plane, one behind the camera and a huge one partly behind the camera.
TestMesh mixed_scene() {
  TestMesh m = fixtures::icosphere(2, Vec3d(-0.2, 0.1, 3.0), 0.8);
  append(m, fixtures::icosphere(1, Vec3d(0.4, -0.1, 2.6), 0.5));
  add_triangle(m, Vec3d(-0.5, -0.6, 0.05), Vec3d(0.6, -0.4, 0.005), Vec3d(0.1, 0.5, 0.03));  // crosses near 0.01
  add_triangle(m, Vec3d(-1, -1, -2), Vec3d(1, -1, -2), Vec3d(0, 1, -2));                     // behind camera
  add_triangle(m, Vec3d(-30, 8, -5), Vec3d(30, 8, 20), Vec3d(0, -2, 6));                     // partly behind
  return m;
}

Camera test_camera(int w, int h) {
  Camera cam;
  cam.width = w;
  cam.height = h;
  cam.fx = 0.9f * w;
  cam.fy = 0.95f * w;
  cam.cx = w * 0.47f;
  cam.cy = h * 0.53f;
  return cam;
}

bool all_finite(const MeshRaster& r) {
  for (int p = 0; p < r.num_pixels(); ++p) {
    if (!std::isfinite(r.bary[3 * p]) || !std::isfinite(r.bary[3 * p + 1]) || !std::isfinite(r.bary[3 * p + 2]))
      return false;
    if (r.tri[p] >= 0 ? !std::isfinite(r.depth[p]) : !(std::isinf(r.depth[p]) && r.depth[p] > 0)) return false;
  }
  return true;
}

}  // namespace

TEST(MeshRaster, MatchesDoubleBruteForceReference) {
  const TestMesh m = mixed_scene();
  const Camera cam = test_camera(96, 80);
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  ASSERT_TRUE(all_finite(r));
  int checked = 0, ambiguous = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const int p = y * cam.width + x;
      const RefHit ref = reference_pixel(cam, m, x, y, 1e-4);
      if (ref.ambiguous) {
        ++ambiguous;
        const bool ok = r.tri[p] == ref.tri ||
                        std::find(ref.candidates.begin(), ref.candidates.end(), r.tri[p]) != ref.candidates.end() ||
                        (r.tri[p] < 0);
        EXPECT_TRUE(ok) << "pixel " << x << "," << y;
        continue;
      }
      ++checked;
      ASSERT_EQ(r.tri[p], ref.tri) << "pixel " << x << "," << y;
      if (ref.tri < 0) continue;
      EXPECT_NEAR(r.depth[p], ref.z, 1e-5 * ref.z) << x << "," << y;
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(r.bary[3 * p + i], ref.b[i], 2e-4) << x << "," << y;
      EXPECT_EQ(r.mask[p], 1.0f);
    }
  // The comparison must cover the image, not just a few pixels.
  EXPECT_GT(checked, 0.9 * cam.width * cam.height);
  EXPECT_LT(ambiguous, 0.1 * cam.width * cam.height);
}

TEST(MeshRaster, MatchesOwnRuleWithoutTilesOrBoxes) {
  // Same coverage rule, no binning: checks tiles and bounding boxes lose nothing, including
  // for near-plane-clipped and screen-filling triangles.
  const TestMesh m = mixed_scene();
  for (int w : {37, 64, 100}) {
    const Camera cam = test_camera(w, w * 3 / 4);
    MeshRaster r;
    rasterize_mesh(cam, view(m), r);
    const std::vector<int> ids = exact_rule_brute_force(cam, m);
    for (int p = 0; p < r.num_pixels(); ++p) ASSERT_EQ(r.tri[p], ids[p]) << "w " << w << " pixel " << p;
  }
}

TEST(MeshRaster, ClosedMeshIsWatertightFromManyViews) {
  // For a closed, consistently oriented mesh every ray enters exactly as often as it leaves:
  // at every pixel the number of front-facing triangles covering it equals the number of
  // back-facing ones (a crack shows as an unmatched entry, double coverage as an extra one).
  // For a convex mesh both counts are 0 or 1.
  const TestMesh sphere = fixtures::icosphere(3, Vec3d(0.1, -0.05, 0.0), 1.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  int covered_total = 0;
  for (int view_i = 0; view_i < 6; ++view_i) {
    Vec3d eye(U(rng), U(rng), U(rng));
    eye = eye * ((view_i == 0 ? 1.3 : 2.0 + 2.0 * std::fabs(U(rng))) / norm(eye));  // view 0: sphere fills the screen
    const Camera cam = fixtures::look_at_camera(72, 64, 60, eye, Vec3d(0.1 * U(rng), 0.1 * U(rng), 0.1 * U(rng)),
                                               Vec3d(U(rng), 1, U(rng)));
    std::vector<TriSetup> s(sphere.num_faces());
    std::vector<int> front(sphere.num_faces());
    for (int f = 0; f < sphere.num_faces(); ++f) {
      Vec3f v[3];
      for (int i = 0; i < 3; ++i) v[i] = cam.to_camera(Vec3f::load(&sphere.verts[3 * sphere.faces[3 * f + i]]));
      front[f] = tri_edges(v).det < 0;  // outward normal facing the camera
      if (!setup_triangle(cam, v, &s[f])) s[f].det = 0;
    }
    MeshRaster r;
    rasterize_mesh(cam, view(sphere), r);
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        int nf = 0, nb = 0;
        const Vec3f d = pixel_ray(cam, x, y);
        for (int f = 0; f < sphere.num_faces(); ++f) {
          float z;
          if (s[f].det > 0 && tri_covers(s[f], d, cam.near_plane, cam.far_plane, &z)) (front[f] ? nf : nb)++;
        }
        ASSERT_EQ(nf, nb) << "view " << view_i << " pixel " << x << "," << y;
        ASSERT_LE(nf, 1) << "view " << view_i << " pixel " << x << "," << y;
        const int p = y * cam.width + x;
        ASSERT_EQ(r.tri[p] >= 0, nf == 1);
        if (nf == 1) {
          EXPECT_TRUE(front[r.tri[p]]) << "the visible surface of a convex mesh faces the camera";
          ++covered_total;
        }
      }
  }
  EXPECT_GT(covered_total, 4000);
}

TEST(MeshRaster, NoHolesInsideSphereSilhouette) {
  // Pixels whose ray passes the (analytic) inscribed sphere well inside are covered.
  const double radius = 1.0;
  const TestMesh sphere = fixtures::icosphere(3, Vec3d(0, 0, 0), radius);
  const Camera cam = fixtures::look_at_camera(128, 128, 150, Vec3d(0.3, 0.2, 3.0), Vec3d(0, 0, 0));
  MeshRaster r;
  rasterize_mesh(cam, view(sphere), r);
  const CameraT<double> c = cam.cast<double>();
  const Mat3d Rt = transpose(c.R);
  const Vec3d eye = -(Rt * c.t);
  int inside = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Vec3d d = Rt * pixel_ray(c, x, y);
      d = d / norm(d);
      const double dist = norm(cross(d, -eye));  // distance from the centre to the ray
      if (dist < 0.95 * radius) {                // level-3 icosphere: inscribed radius > 0.99
        ++inside;
        EXPECT_GE(r.tri[y * cam.width + x], 0) << x << "," << y;
      }
    }
  EXPECT_GT(inside, 2000);
}

TEST(MeshRaster, PixelExactlyOnSharedEdgeDrawnOnce) {
  // A square at z = 1 split along its diagonal; with dyadic camera numbers the diagonal
  // passes exactly through the pixel centres with x == y (edge function exactly 0), and
  // the square's sides lie exactly on pixel boundaries.
  for (bool flip_diag : {false, true}) {
    TestMesh m;
    const Vec3d a(-0.25, -0.25, 1), b(0.25, -0.25, 1), c(0.25, 0.25, 1), d(-0.25, 0.25, 1);
    m.verts = {float(a.x), float(a.y), 1, float(b.x), float(b.y), 1, float(c.x), float(c.y), 1, float(d.x), float(d.y), 1};
    if (!flip_diag)
      m.faces = {0, 1, 2, 0, 2, 3};  // diagonal a-c, both triangles clockwise in the image
    else
      m.faces = {1, 2, 3, 1, 3, 0};  // diagonal b-d
    Camera cam;
    cam.width = cam.height = 64;
    cam.fx = cam.fy = 64;
    cam.cx = cam.cy = 32;
    MeshRaster r;
    rasterize_mesh(cam, view(m), r);
    std::vector<TriSetup> s(2);
    for (int f = 0; f < 2; ++f) {
      Vec3f v[3];
      for (int i = 0; i < 3; ++i) v[i] = Vec3f::load(&m.verts[3 * m.faces[3 * f + i]]);
      ASSERT_TRUE(setup_triangle(cam, v, &s[f]));
    }
    int on_edge = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool in_square = x >= 16 && x < 48 && y >= 16 && y < 48;
        float z;
        const Vec3f dd = pixel_ray(cam, x, y);
        const int n = int(tri_covers(s[0], dd, cam.near_plane, cam.far_plane, &z)) +
                      int(tri_covers(s[1], dd, cam.near_plane, cam.far_plane, &z));
        ASSERT_EQ(n, in_square ? 1 : 0) << x << "," << y;
        ASSERT_EQ(r.tri[y * 64 + x] >= 0, in_square);
        const bool diag = flip_diag ? (x + y == 63) : (x == y);
        if (in_square && diag) {
          ++on_edge;
          const float* bb = &r.bary[3 * (y * 64 + x)];
          // Exactly on the diagonal: the barycentric of the vertex off the diagonal is 0.
          EXPECT_EQ(std::min({bb[0], bb[1], bb[2]}), 0.0f);
          EXPECT_EQ(r.depth[y * 64 + x], 1.0f);
        }
      }
    EXPECT_EQ(on_edge, 32);
  }
}

TEST(MeshRaster, PerspectiveCorrectBarycentricsReproduceLinearAttribute) {
  // A strongly tilted triangle spanning depths 0.5 .. 6: interpolating the world positions
  // of its vertices must give the 3D point the pixel sees (ray * depth), which affine
  // screen-space interpolation would not.
  TestMesh m;
  add_triangle(m, Vec3d(-1.0, -0.8, 0.5), Vec3d(2.5, -0.5, 6.0), Vec3d(-0.5, 2.0, 4.0));
  const Camera cam = fixtures::look_at_camera(80, 80, 70, Vec3d(0.2, -0.1, -0.6), Vec3d(0.3, 0.2, 3));
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  std::vector<float> pos(size_t(r.num_pixels()) * 3);
  interpolate(r.num_pixels(), r.tri.data(), r.bary.data(), m.faces.data(), m.verts.data(), 3, pos.data());
  const CameraT<double> c = cam.cast<double>();
  const Mat3d Rt = transpose(c.R);
  int n = 0;
  double max_err_affine = 0;
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x < 80; ++x) {
      const int p = y * 80 + x;
      if (r.tri[p] < 0) continue;
      ++n;
      const Vec3d hit = Rt * (double(r.depth[p]) * pixel_ray(c, x, y) - c.t);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(pos[3 * p + k], hit[k], 2e-5 * (1 + std::fabs(hit[k])));
      // The same attribute interpolated affinely in screen space (projected-vertex
      // barycentrics) is visibly wrong here: shows the test can fail.
      Vec2<double> q[3];
      for (int i = 0; i < 3; ++i) q[i] = c.project(c.to_camera(Vec3d(Vec3f::load(&m.verts[3 * i]))));
      const Vec2<double> pc(x + 0.5, y + 0.5);
      auto area = [](Vec2<double> a, Vec2<double> b, Vec2<double> cc) {
        return (b.x - a.x) * (cc.y - a.y) - (b.y - a.y) * (cc.x - a.x);
      };
      const double A = area(q[0], q[1], q[2]);
      const double s[3] = {area(pc, q[1], q[2]) / A, area(q[0], pc, q[2]) / A, area(q[0], q[1], pc) / A};
      double ax = 0;
      for (int i = 0; i < 3; ++i) ax += s[i] * m.verts[3 * i];
      max_err_affine = std::max(max_err_affine, std::fabs(ax - hit.x));
    }
  EXPECT_GT(n, 500);
  EXPECT_GT(max_err_affine, 0.1);
}

TEST(MeshRaster, BarycentricsFunctionReproducesRasterOutput) {
  const TestMesh m = mixed_scene();
  const Camera cam = test_camera(64, 48);
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  std::vector<float> b(size_t(r.num_pixels()) * 3), z(r.num_pixels());
  mesh_barycentrics(cam, view(m), r.tri.data(), b.data(), z.data());
  for (int p = 0; p < r.num_pixels(); ++p) {
    for (int i = 0; i < 3; ++i) ASSERT_EQ(b[3 * p + i], r.bary[3 * p + i]) << p;
    ASSERT_EQ(z[p], r.depth[p]) << p;
    if (r.tri[p] >= 0) {
      for (int i = 0; i < 3; ++i) EXPECT_GE(r.bary[3 * p + i], 0.0f);
      EXPECT_NEAR(r.bary[3 * p] + r.bary[3 * p + 1] + r.bary[3 * p + 2], 1.0f, 1e-6f);
    }
  }
}

TEST(MeshRaster, NearPlaneClipsPerPixel) {
  // A triangle from z = 0.002 to z = 0.5 with near = 0.01: drawn exactly where its depth is
  // >= near, nothing nearer; a wide triangle with a vertex behind the camera draws only its
  // part in front.
  TestMesh m;
  add_triangle(m, Vec3d(-0.01, -0.01, 0.002), Vec3d(0.3, -0.1, 0.5), Vec3d(-0.1, 0.3, 0.5));
  add_triangle(m, Vec3d(-2, 0.4, 3), Vec3d(2, 0.4, 3), Vec3d(0, 0.1, -1));
  const Camera cam = test_camera(64, 64);
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  ASSERT_TRUE(all_finite(r));
  int n0 = 0, n1 = 0;
  for (int p = 0; p < r.num_pixels(); ++p) {
    if (r.tri[p] < 0) continue;
    EXPECT_GE(r.depth[p], cam.near_plane);
    (r.tri[p] == 0 ? n0 : n1)++;
  }
  EXPECT_GT(n0, 100);
  EXPECT_GT(n1, 100);
  const std::vector<int> ids = exact_rule_brute_force(cam, m);
  for (int p = 0; p < r.num_pixels(); ++p) EXPECT_EQ(r.tri[p], ids[p]);
  // Check the clipped region against the double reference.
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const RefHit ref = reference_pixel(cam, m, x, y, 1e-4);
      if (!ref.ambiguous) {
        EXPECT_EQ(r.tri[y * 64 + x], ref.tri) << x << "," << y;
      }
    }
}

TEST(MeshRaster, HardCasesDrawNothingAndStayFinite) {
  const Camera cam = test_camera(48, 40);
  TestMesh m;
  add_triangle(m, Vec3d(0.1, 0, 1), Vec3d(0.2, 0, 2), Vec3d(0.1, 0.3, 1));   // 0: edge-on (plane through camera)
  add_triangle(m, Vec3d(0, 0, 2), Vec3d(0.2, 0.1, 2), Vec3d(0.4, 0.2, 2));   // 1: collinear, zero area
  add_triangle(m, Vec3d(0.1, 0.1, 2), Vec3d(0.1, 0.1, 2), Vec3d(0.3, 0, 2));  // 2: repeated vertex
  add_triangle(m, Vec3d(-1, -1, -1), Vec3d(1, -1, -1), Vec3d(0, 1, -0.5));   // 3: behind the camera
  add_triangle(m, Vec3d(-1, -1, 200), Vec3d(1, -1, 200), Vec3d(0, 1, 200));  // 4: beyond far
  add_triangle(m, Vec3d(NAN, 0, 2), Vec3d(1, 0, 2), Vec3d(0, 1, 2));         // 5: NaN vertex
  add_triangle(m, Vec3d(-0.2, -0.2, 2), Vec3d(0.2, -0.2, 2), Vec3d(0, 0.2, 2));  // 6: ordinary
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  ASSERT_TRUE(all_finite(r));
  int n6 = 0;
  for (int p = 0; p < r.num_pixels(); ++p) {
    EXPECT_TRUE(r.tri[p] == -1 || r.tri[p] == 6) << r.tri[p];
    n6 += r.tri[p] == 6;
  }
  EXPECT_GT(n6, 20);

  // Empty mesh: nothing, depth +inf, mask 0.
  MeshRaster e;
  rasterize_mesh(cam, MeshView{}, e);
  for (int p = 0; p < e.num_pixels(); ++p) {
    EXPECT_EQ(e.tri[p], -1);
    EXPECT_TRUE(std::isinf(e.depth[p]));
    EXPECT_EQ(e.mask[p], 0.0f);
  }
}

TEST(MeshRaster, VertexOnCameraPlaneAndScreenFillingTriangle) {
  // A vertex at z = 0 (projection undefined) and a triangle enclosing the camera's view.
  const Camera cam = test_camera(40, 40);
  TestMesh m;
  add_triangle(m, Vec3d(0.5, 0, 0), Vec3d(-0.3, -0.2, 1), Vec3d(-0.3, 0.3, 1));
  add_triangle(m, Vec3d(-100, -100, 5), Vec3d(100, -100, 5), Vec3d(0, 100, 5));
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  ASSERT_TRUE(all_finite(r));
  for (int p = 0; p < r.num_pixels(); ++p) EXPECT_GE(r.tri[p], 0);  // the big one fills the rest
  const std::vector<int> ids = exact_rule_brute_force(cam, m);
  for (int p = 0; p < r.num_pixels(); ++p) EXPECT_EQ(r.tri[p], ids[p]);
}

TEST(MeshRaster, SameResultWithOneOrTwoThreads) {
  const TestMesh m = fixtures::body_like_mesh(12, 16);
  const Camera cam = fixtures::look_at_camera(96, 96, 110, Vec3d(0.5, 0.3, 2.5), Vec3d(0, 0, 0));
  MeshRaster a, b;
  const int saved = num_threads();
  set_num_threads(1);
  rasterize_mesh(cam, view(m), a);
  set_num_threads(2);
  rasterize_mesh(cam, view(m), b);
  set_num_threads(saved);
  EXPECT_EQ(a.tri, b.tri);
  EXPECT_EQ(a.bary, b.bary);
  EXPECT_EQ(a.depth, b.depth);
}

TEST(MeshRaster, BadInputThrows) {
  TestMesh m;
  add_triangle(m, Vec3d(0, 0, 1), Vec3d(1, 0, 1), Vec3d(0, 1, 1));
  Camera cam = test_camera(8, 8);
  MeshRaster r;
  m.faces[1] = 7;
  EXPECT_THROW(rasterize_mesh(cam, view(m), r), Error);
  m.faces[1] = -1;
  EXPECT_THROW(rasterize_mesh(cam, view(m), r), Error);
  m.faces[1] = 1;
  cam.near_plane = 0;
  EXPECT_THROW(rasterize_mesh(cam, view(m), r), Error);
  cam.near_plane = 0.01f;
  cam.fx = 0;
  EXPECT_THROW(rasterize_mesh(cam, view(m), r), Error);
  cam.fx = 8;
  cam.width = 0;
  EXPECT_THROW(rasterize_mesh(cam, view(m), r), Error);
  try {
    cam.width = 8;
    m.faces[2] = 3;
    rasterize_mesh(cam, view(m), r);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rasterize_mesh: face 0"), std::string::npos) << e.what();
  }
}

TEST(MeshRaster, SharedEdgeNormalsAreExactNegations) {
  // The watertightness argument: the two directions of an edge give bit-exact opposite edge
  // normals, whatever the coordinates (computed in one canonical order of the endpoints).
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(-3, 3);
  for (int k = 0; k < 10000; ++k) {
    Vec3f a(U(rng), U(rng), 2 + U(rng)), b(U(rng), U(rng), 2 + U(rng));
    if (k % 3 == 0) b.x = a.x;  // ties in the ordering
    if (k % 9 == 0) b.y = a.y;
    const Vec3f n1 = edge_normal(a, b), n2 = edge_normal(b, a);
    ASSERT_EQ(n1.x, -n2.x);
    ASSERT_EQ(n1.y, -n2.y);
    ASSERT_EQ(n1.z, -n2.z);
    const Vec3f d(U(rng) / 3, U(rng) / 3, 1);
    ASSERT_EQ(dot(d, n1), -dot(d, n2));
  }
}

TEST(MeshRaster, KilometreSizedGroundTriangleIsDrawn) {
  // Large coordinates must not overflow the setup (a ground plane 1.5 m below the camera,
  // reaching 5 km; the far plane cuts it at 100 m).
  TestMesh m;
  add_triangle(m, Vec3d(-5000, 1.5, -10), Vec3d(5000, 1.5, -10), Vec3d(0, 1.5, 5000));
  const Camera cam = test_camera(64, 48);
  MeshRaster r;
  rasterize_mesh(cam, view(m), r);
  ASSERT_TRUE(all_finite(r));
  int n = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      const int p = y * 64 + x;
      if (r.tri[p] < 0) continue;
      ++n;
      EXPECT_GT(y + 0.5, cam.cy) << "ground is below the horizon";
      EXPECT_NEAR(r.depth[p], 1.5 * cam.fy / (y + 0.5 - cam.cy), 1e-4 * r.depth[p]);
    }
  EXPECT_GT(n, 200);
}
