// Mesh rasterizer: per pixel the visible triangle, perspective-correct barycentrics,
// camera-space depth and the silhouette; plus the differentiable pieces that turn
// vertex positions into per-pixel values with visibility held fixed.
//
// Method (homogeneous rasterization, no screen-space division): for a camera-space
// triangle v0, v1, v2 and the ray d = ((px - cx) / fx, (py - cy) / fy, 1) through a pixel
// centre, the edge functions E_i = dot(d, cross(v_j, v_k)) ((i, j, k) cyclic) are linear in
// the pixel, and
//     b_i = E_i / (E_0 + E_1 + E_2)      (barycentrics of the 3D hit point: perspective-correct)
//     z   = det / dot(d, N)              (camera z of the hit point; det = dot(v0, N),
//                                         N = cross(v1 - v0, v2 - v0) = sum of the E normals)
// A pixel is covered when every sign(det) * E_i >= 0 (ties broken by the top-left rule
// below) and near <= z <= far. This needs no clipping: vertices behind the camera are
// handled exactly, and the near plane is applied per pixel (exactly what clipping the
// triangle at z = near would draw). Only the pixel bounding box is computed from the
// triangle clipped at z = near.
//
// Coverage cut (optional, MeshView::coverage, Avatar::mesh_coverage): a point of a face draws
// only where the barycentric interpolation of its corners' coverage c_i is >= kCoverageCutoff,
// i.e. sum_i E_i (c_i - cutoff) >= 0 (sum_i E_i > 0 inside); what lies behind a cut point
// shows, as a glTF viewer's alpha test (MASK) shows it. A face with every corner under the
// cutoff is skipped at setup; one with none under it draws whole.
//
// Culling (documented, tested): no back-face culling (both sides draw; the z-buffer picks).
// Skipped triangles: any non-finite vertex; zero area; edge-on (|det| <= 1e-6 |N| |v0|,
// the plane passes within a relative 1e-6 of the camera centre); entirely behind the near
// plane or beyond the far plane.
//
// Watertightness: the edge normal of an edge is computed from its two vertices in a
// canonical order (lexicographically smaller point first) and negated for the opposite direction, so two
// triangles sharing an edge get exactly opposite edge values at every pixel (IEEE rounding
// is sign-symmetric). With the top-left rule (a pixel exactly on an edge, E_i == 0, belongs
// to the triangle whose normalized edge normal has n.x > 0, or n.x == 0 and n.y > 0) a
// pixel centre on a shared edge of two consistently oriented triangles is drawn by exactly
// one of them: no cracks, no double coverage. Depth ties go to the lower triangle index.
//
// Threads: triangles are binned into 16 x 16 pixel tiles; tiles run in parallel.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "body/avatar.h"
#include "core/math.h"
#include "core/camera.h"

namespace haha {

// Borrowed triangle mesh (not owned): world-space positions (V, 3), faces (F, 3) of vertex
// indices into verts.
template <class T>
struct MeshViewT {
  const T* verts = nullptr;
  int num_verts = 0;
  const int32_t* faces = nullptr;
  int num_faces = 0;
  // (V) per-vertex coverage in [0, 1] for the cut above; null: every face draws whole.
  // Only rasterize_mesh reads it (visibility); the differentiable parts take tri as given.
  const float* coverage = nullptr;
};
using MeshView = MeshViewT<float>;

// ---------------------------------------------------------------------------------------
// Per-pixel kernels (host and device), shared by the CPU launchers, the tests and a
// future CUDA backend.

constexpr float kEdgeOnRelEps = 1e-6f;  // |det| <= eps |N| |v0|: edge-on, skipped
constexpr int kRasterTile = 16;         // tile side in pixels

// Ray through the centre of pixel (x, y), camera space, z = 1.
template <class T>
HAHA_HD Vec3<T> pixel_ray(const CameraT<T>& cam, int x, int y) {
  return {(T(x) + T(0.5) - cam.cx) / cam.fx, (T(y) + T(0.5) - cam.cy) / cam.fy, T(1)};
}

// Normal of the edge plane through the camera centre, v_a and v_b, for the directed edge
// a -> b, computed in a canonical order (lexicographically smaller camera-space point
// first) so the opposite direction gives the exact negation, also for meshes that duplicate
// vertices. cross(v_a, v_b) = cross(v_a, v_b - v_a) keeps precision for small, distant
// triangles.
template <class T>
HAHA_HD bool lex_less_equal(Vec3<T> a, Vec3<T> b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z <= b.z;
}
template <class T>
HAHA_HD Vec3<T> edge_normal(Vec3<T> va, Vec3<T> vb) {
  if (lex_less_equal(va, vb)) return cross(va, vb - va);
  return -cross(vb, va - vb);
}

// Edge normals n_i (plane of the camera centre and the edge opposite vertex i), the area
// normal N and det = dot(v0, N) of a camera-space triangle.
template <class T>
struct TriEdges {
  Vec3<T> n[3];
  Vec3<T> N;
  T det;
};
template <class T>
HAHA_HD TriEdges<T> tri_edges(const Vec3<T> v[3]) {
  TriEdges<T> e;
  e.n[0] = edge_normal(v[1], v[2]);
  e.n[1] = edge_normal(v[2], v[0]);
  e.n[2] = edge_normal(v[0], v[1]);
  e.N = cross(v[1] - v[0], v[2] - v[0]);
  e.det = dot(v[0], e.N);
  return e;
}

// Barycentrics and camera z of the ray d on the triangle's plane (no inside test).
template <class T>
HAHA_HD void tri_bary_depth(const TriEdges<T>& e, Vec3<T> d, T b[3], T* z) {
  const T E0 = dot(d, e.n[0]), E1 = dot(d, e.n[1]), E2 = dot(d, e.n[2]);
  const T inv = T(1) / (E0 + E1 + E2);
  b[0] = E0 * inv;
  b[1] = E1 * inv;
  b[2] = E2 * inv;
  *z = e.det / dot(d, e.N);
}

// Raster setup of one triangle: edge normals multiplied by sign(det) so that "inside" is
// all E_i >= 0, pixel bounding box (inclusive; x0 > x1 when culled), top-left bits.
struct TriSetup {
  Vec3f n[3];
  Vec3f N;           // area normal * sign(det)
  float det;         // |det| > 0
  int x0, y0, x1, y1;
  uint32_t top_left;  // bit i: edge i owns pixels with E_i == 0; kCutBit: the coverage cut applies
  float cut[3];       // c_i - kCoverageCutoff per corner (read when kCutBit is set)
};
constexpr uint32_t kCutBit = 1u << 3;

// Coverage of the ray d (through a pixel centre) by a set-up triangle, with the fill rule
// and the near/far test. On coverage writes the camera z.
HAHA_HD bool tri_covers(const TriSetup& s, Vec3f d, float near_plane, float far_plane, float* z) {
  float cut = 0.0f;
  for (int i = 0; i < 3; ++i) {
    const float E = s.n[i].x * d.x + s.n[i].y * d.y + s.n[i].z;
    if (E < 0.0f || (E == 0.0f && !((s.top_left >> i) & 1u))) return false;
    cut += E * s.cut[i];
  }
  if ((s.top_left & kCutBit) && cut < 0.0f) return false;
  const float den = s.N.x * d.x + s.N.y * d.y + s.N.z;
  if (!(den > 0.0f)) return false;
  const float zz = s.det / den;
  if (!(zz >= near_plane && zz <= far_plane)) return false;
  *z = zz;
  return true;
}

// Pixel index range [lo, hi] whose centres (i + 0.5) can lie in [a, b], with a margin for
// the rounding difference between projection and edge functions; clamped to [0, n - 1].
HAHA_HD float min_f(float a, float b) { return a < b ? a : b; }  // inlined (std::fmin is a libm call)
HAHA_HD float max_f(float a, float b) { return a > b ? a : b; }
HAHA_HD void pixel_span(float a, float b, int n, int* lo, int* hi) {
  const float m = 0.01f + 1e-5f * max_f(std::fabs(a), std::fabs(b));
  const float fa = min_f(max_f(a - 0.5f - m, -2.0f), float(n) + 2.0f);
  const float fb = min_f(max_f(b - 0.5f + m, -2.0f), float(n) + 2.0f);
  const int l = int(std::ceil(fa)), h = int(std::floor(fb));
  *lo = l > 0 ? l : 0;
  *hi = h < n - 1 ? h : n - 1;
}

// Builds the setup of the camera-space triangle v. Returns false (and an empty box) for
// skipped triangles (see culling above).
HAHA_HD bool setup_triangle(const Camera& cam, const Vec3f v[3], TriSetup* s) {
  s->x0 = s->y0 = 0;
  s->x1 = s->y1 = -1;
  s->top_left = 0;
  s->cut[0] = s->cut[1] = s->cut[2] = 0.0f;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v[i].x) || !std::isfinite(v[i].y) || !std::isfinite(v[i].z)) return false;
  const float nr = cam.near_plane, fr = cam.far_plane;
  const float zmin = min_f(v[0].z, min_f(v[1].z, v[2].z)), zmax = max_f(v[0].z, max_f(v[1].z, v[2].z));
  if (zmax < nr || zmin > fr) return false;

  const TriEdges<float> e = tri_edges(v);
  // Edge-on or degenerate: |det| <= eps |N| |v0|; also rejects zero area and non-finite
  // values (comparisons with NaN are false).
  if (!std::isfinite(e.det) || !(std::fabs(e.det) > kEdgeOnRelEps * norm(e.N) * norm(v[0]))) return false;
  const float sg = e.det > 0 ? 1.0f : -1.0f;  // multiplying by -1 is an exact negation
  for (int i = 0; i < 3; ++i) {
    s->n[i] = sg * e.n[i];
    if (s->n[i].x > 0.0f || (s->n[i].x == 0.0f && s->n[i].y > 0.0f)) s->top_left |= 1u << i;
  }
  s->N = sg * e.N;
  s->det = sg * e.det;

  // Bounding box of the part at z >= near: clip the triangle polygon at the near plane
  // (one Sutherland-Hodgman step, at most 4 vertices), project, take the extent.
  Vec3f poly[4];
  int np = 0;
  for (int i = 0; i < 3; ++i) {
    const Vec3f a = v[i], b = v[(i + 1) % 3];
    const bool ina = a.z >= nr, inb = b.z >= nr;
    if (ina) poly[np++] = a;
    if (ina != inb) {
      const float t = (nr - a.z) / (b.z - a.z);
      Vec3f p = a + t * (b - a);
      p.z = nr;
      poly[np++] = p;
    }
  }
  if (np < 3) return false;
  float minx = INFINITY, maxx = -INFINITY, miny = INFINITY, maxy = -INFINITY;
  for (int i = 0; i < np; ++i) {
    const Vec2f q = cam.project(poly[i]);
    minx = min_f(minx, q.x);
    maxx = max_f(maxx, q.x);
    miny = min_f(miny, q.y);
    maxy = max_f(maxy, q.y);
  }
  if (!(minx <= maxx && miny <= maxy)) return false;  // NaN from overflow
  pixel_span(minx, maxx, cam.width, &s->x0, &s->x1);
  pixel_span(miny, maxy, cam.height, &s->y0, &s->y1);
  return s->x0 <= s->x1 && s->y0 <= s->y1;
}

// The coverage cut of a set-up face with corner vertices idx (coverage per vertex, null:
// none): every corner under the cutoff empties its box; a mix sets kCutBit.
HAHA_HD void setup_coverage_cut(const float* coverage, const int32_t idx[3], TriSetup* s) {
  if (!coverage) return;
  int under = 0;
  for (int i = 0; i < 3; ++i) {
    s->cut[i] = coverage[idx[i]] - kCoverageCutoff;
    under += s->cut[i] < 0.0f;
  }
  if (under == 3) {
    s->x0 = s->y0 = 0;
    s->x1 = s->y1 = -1;
  } else if (under > 0) {
    s->top_left |= kCutBit;
  }
}

// Camera-space corners of face f.
template <class T>
HAHA_HD void load_triangle(const CameraT<T>& cam, const MeshViewT<T>& mesh, int f, Vec3<T> v[3], int idx[3]) {
  for (int i = 0; i < 3; ++i) {
    idx[i] = mesh.faces[3 * f + i];
    v[i] = cam.to_camera(Vec3<T>::load(mesh.verts + 3 * idx[i]));
  }
}

// Kernel of mesh_barycentrics for a covered pixel (x, y) of face f.
template <class T>
HAHA_HD void barycentrics_pixel(const CameraT<T>& cam, const MeshViewT<T>& mesh, int f, int x, int y, T b[3], T* z) {
  Vec3<T> v[3];
  int idx[3];
  load_triangle(cam, mesh, f, v, idx);
  tri_bary_depth(tri_edges(v), pixel_ray(cam, x, y), b, z);
}

// Kernel of mesh_barycentrics_backward for a covered pixel (x, y) of face f: world-space
// gradients of its three corners (vertex ids idx) for dL/db (gb) and dL/dz (gz).
//   b_i = E_i / S, z = det / S, S = sum_i E_i (= dot(d, N)),
//   E_i = det[d, v_j, v_k]  ->  dE_i/dv_j = cross(v_k, d), dE_i/dv_k = cross(d, v_j),
//   det = det[v0, v1, v2]   ->  ddet/dv_i = cross(v_j, v_k).
template <class T>
HAHA_HD void barycentrics_backward_pixel(const CameraT<T>& cam, const MeshViewT<T>& mesh, int f, int x, int y,
                                         const T gb[3], T gz, int idx[3], Vec3<T> gw[3]) {
  Vec3<T> v[3];
  load_triangle(cam, mesh, f, v, idx);
  const TriEdges<T> e = tri_edges(v);
  const Vec3<T> d = pixel_ray(cam, x, y);
  const T E[3] = {dot(d, e.n[0]), dot(d, e.n[1]), dot(d, e.n[2])};
  const T S = E[0] + E[1] + E[2];
  const T b[3] = {E[0] / S, E[1] / S, E[2] / S};
  const T z = e.det / S;
  const T common = gb[0] * b[0] + gb[1] * b[1] + gb[2] * b[2] + gz * z;
  T gE[3];
  for (int i = 0; i < 3; ++i) gE[i] = (gb[i] - common) / S;
  const T gdet = gz / S;
  Vec3<T> gv[3];
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    gv[j] += gE[i] * cross(v[k], d);
    gv[k] += gE[i] * cross(d, v[j]);
    gv[i] += gdet * cross(v[j], v[k]);
  }
  const Mat3<T> Rt = transpose(cam.R);  // x_cam = R x + t
  for (int i = 0; i < 3; ++i) gw[i] = Rt * gv[i];
}

// Kernel of interpolate for a covered pixel p (tri f >= 0): out[0..C) = sum_i b_i attr(idx_i).
template <class T>
HAHA_HD void interpolate_pixel(int64_t p, int f, const T* bary, const int32_t* attr_index, const T* attr,
                               int C, T* out) {
  const T* b = bary + 3 * p;
  const T* a0 = attr + int64_t(attr_index[3 * f]) * C;
  const T* a1 = attr + int64_t(attr_index[3 * f + 1]) * C;
  const T* a2 = attr + int64_t(attr_index[3 * f + 2]) * C;
  for (int c = 0; c < C; ++c) out[c] = b[0] * a0[c] + b[1] * a1[c] + b[2] * a2[c];
}

// Kernel of interpolate_backward w.r.t. the barycentrics of a covered pixel: gb (3) written.
template <class T>
HAHA_HD void interpolate_backward_bary_pixel(int f, const int32_t* attr_index, const T* attr, int C, const T* g,
                                             T* gb) {
  for (int i = 0; i < 3; ++i) {
    const T* a = attr + int64_t(attr_index[3 * f + i]) * C;
    T s = 0;
    for (int c = 0; c < C; ++c) s += g[c] * a[c];
    gb[i] = s;
  }
}

// Kernel of interpolate_backward w.r.t. the attribute of a covered pixel p: scatter-adds
// b_i g into the three corners' rows of ga through `add` (core/hd.h).
template <class T, class Add = PlainAdd>
HAHA_HD void interpolate_backward_attr_pixel(int64_t p, int f, const T* bary, const int32_t* attr_index, int C,
                                             const T* g, T* ga, Add add = {}) {
  const T* b = bary + 3 * p;
  for (int i = 0; i < 3; ++i) {
    T* a = ga + int64_t(attr_index[3 * f + i]) * C;
    for (int c = 0; c < C; ++c) add(&a[c], b[i] * g[c]);
  }
}

// ---------------------------------------------------------------------------------------
// Per-pixel result of rasterize_mesh; pixel p = y * width + x. Vectors are resized by the
// rasterizer (capacity is reused between calls of the same size).
struct MeshRaster {
  int width = 0, height = 0;
  std::vector<int32_t> tri;   // (H*W) visible triangle index, -1 = none
  std::vector<float> bary;    // (H*W, 3) perspective-correct barycentrics, 0 where tri < 0
  std::vector<float> depth;   // (H*W) camera-space z of the visible point, +inf where tri < 0
  std::vector<float> mask;    // (H*W) silhouette: 1 where tri >= 0, else 0
  int num_pixels() const { return width * height; }

  // Scratch reused between calls (camera-space vertices, triangle setups, tile bins).
  std::vector<float> scratch_cam_verts;
  std::vector<TriSetup> scratch_setup;
  std::vector<int32_t> scratch_bin_start, scratch_bin_items, scratch_tri_tiles;
};

// Forward rasterization (float). Throws haha::Error (message starts "rasterize_mesh:") on a
// camera with non-positive size/focal, near <= 0 or far <= near, or a face index out of
// [0, V). Non-finite vertices are not an error: their triangles are skipped.
void rasterize_mesh(const Camera& cam, const MeshView& mesh, MeshRaster& out);


// Optional (nullable) buffers are not used to deduce T, so nullptr can be passed directly.
template <class T>
using NoDeduce = std::type_identity_t<T>;

// ---------------------------------------------------------------------------------------
// Differentiable part. Visibility (tri) is an input held fixed; barycentrics and depth are
// recomputed from the vertices, so a finite-difference test can move vertices in double
// while keeping the triangle map. rasterize_mesh's bary/depth come from exactly this
// function (in float).

// bary (P, 3) and depth (P) of each pixel's triangle tri (P) from world vertices; pixels with
// tri < 0 get bary 0 and depth +inf. P = cam.width * cam.height. Either output may be null.
template <class T>
void mesh_barycentrics(const CameraT<T>& cam, const MeshViewT<T>& mesh, const int32_t* tri, NoDeduce<T>* bary,
                       NoDeduce<T>* depth);

// Adds dL/dverts (V, 3, world space) for dL/dbary (P, 3) and dL/ddepth (P, may be null).
// Pixels with tri < 0 contribute nothing. grad_verts is ACCUMULATED (+=).
template <class T>
void mesh_barycentrics_backward(const CameraT<T>& cam, const MeshViewT<T>& mesh, const int32_t* tri,
                                const NoDeduce<T>* grad_bary, const NoDeduce<T>* grad_depth, NoDeduce<T>* grad_verts);

// out(p, c) = sum_i bary(p, i) * attr(attr_index(tri(p), i), c): interpolation of an
// attribute stored per corner through an index (attr_index = faces for per-vertex values,
// = ft for UVs). attr is (N, C); attr_index is (F, 3). out (P, C) is OVERWRITTEN, 0 where
// tri < 0.
template <class T>
void interpolate(int num_pixels, const int32_t* tri, const T* bary, const int32_t* attr_index,
                 const T* attr, int channels, T* out);

// Backward of interpolate. grad_attr (N, C) is ACCUMULATED (may be null); grad_bary (P, 3) is
// OVERWRITTEN (may be null; 0 where tri < 0).
template <class T>
void interpolate_backward(int num_pixels, int num_attr, const int32_t* tri, const T* bary,
                          const int32_t* attr_index, const T* attr, int channels, const NoDeduce<T>* grad_out,
                          NoDeduce<T>* grad_attr, NoDeduce<T>* grad_bary);

}  // namespace haha
