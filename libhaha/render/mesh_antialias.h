// Silhouette antialiasing of a rasterized mesh layer, forward and backward: the pass that
// gives the mesh's silhouette and occlusion boundaries a gradient with respect to the vertex
// positions (the rasterizer's coverage is a hard 0/1 and has none). Same idea as
// nvdiffrast's `antialias` (Laine et al. 2020), written for our layer (colour M and
// coverage m, merged later with the Gaussians and the background):
//
// For each pixel r and each of its 4 neighbours s whose visible triangles differ, the
// nearer of the two (the occluder; a covered pixel is nearer than an empty one) owns the
// pixel pair. Walking from the occluder's triangle along the segment between the two pixel
// centres (across interior edges, into the neighbouring faces), if a silhouette edge (a
// boundary edge, or one whose neighbouring face turns the other way from the camera)
// crosses the segment at parameter t in [0, 1] (0 at the occluder's pixel), the occluder
// covers a fraction of the pair's other pixel, or leaves a fraction of its own, that the
// 1D picture along the segment gives:
//     the other pixel takes w = t - 1/2 of the occluder's pixel   (t > 1/2)
//     the occluder's pixel takes w = 1/2 - t of the other pixel   (t < 1/2)
// Blending is premultiplied (P = m M), so a pixel next to the background gets partial
// coverage m' = w and the occluder's colour. It is separable, rows first, then columns:
//     Ph(q) = (1 - w_left - w_right) P(q) + w_left P(q - 1) + w_right P(q + 1)   (and mh)
//     P'(r) = (1 - w_up - w_down) Ph(r) + w_up Ph(up) + w_down Ph(down)            (and m')
//     M'    = P' / m'   (M_r where m' is below 1e-6: nothing of the pixel's colour shows)
// Every weight is in [0, 1/2], so the coverage stays in [0, 1]; for a rectangle aligned
// with the pixel grid it is exactly each pixel's covered area, corners included. t moves with the projected
// edge, which is where the vertex gradient comes from. Visibility (tri) and the choice of
// the occluder are held fixed, as in the rasterizer's differentiable part.
//
// Hard cases, by construction: an edge with an end behind the near plane is skipped (no
// antialiasing there, never a division by z <= 0); an edge parallel to the pair's axis
// (no crossing) is skipped; an edge through a pixel centre gives t = 0 or 1 (w = 1/2,
// continuous with its neighbours); several partial contributions to one pixel are
// combined separably so the coverage stays in [0, 1].
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/hd.h"
#include "core/math.h"
#include "core/camera.h"
#include "render/mesh_raster.h"

namespace haha {

// For face f and corner i, the face across the edge opposite corner i (corners i+1, i+2),
// or -1 where the edge is a boundary or is shared by more than two faces. Throws
// haha::Error for a face index out of [0, num_verts).
std::vector<int32_t> mesh_face_neighbors(const int32_t* faces, int num_faces, int num_verts);

template <class T>
struct AntialiasInputsT {
  CameraT<T> camera;                   // by value: the struct is passed to device kernels as is
  MeshViewT<T> mesh;                   // world-space vertices and faces of the raster
  const int32_t* neighbors = nullptr;  // (F, 3) from mesh_face_neighbors
  const int32_t* tri = nullptr;        // (P) visible triangle per pixel, -1 = none
  const float* depth = nullptr;        // (P) camera z of the visible point (occluder choice)
  const T* color = nullptr;            // (P, C) M
  const T* mask = nullptr;             // (P) m in [0, 1]
  int channels = 3;
};

// ---------------------------------------------------------------------------------------
// Per-pixel kernels (host and device).

namespace aa_detail {

// The neighbour offsets of a pixel: left, right, up, down.
HAHA_HD void neighbour(int k, int* dx, int* dy) {
  *dx = k == 0 ? -1 : (k == 1 ? 1 : 0);
  *dy = k == 2 ? -1 : (k == 3 ? 1 : 0);
}

template <class T>
HAHA_HD T face_det(const CameraT<T>& cam, const MeshViewT<T>& mesh, int f) {
  Vec3<T> v[3];
  int idx[3];
  load_triangle(cam, mesh, f, v, idx);
  return dot(v[0], cross(v[1] - v[0], v[2] - v[0]));
}

// Where the projected edge a-b (camera space, in front of the camera) crosses the line
// through the pair's pixel centres: `along` is the coordinate along the pair's axis
// (x for a horizontal pair at row centre `line`, y for a vertical pair at column centre
// `line`). False when it does not cross.
template <class T>
HAHA_HD bool edge_crossing(const CameraT<T>& cam, Vec3<T> a, Vec3<T> b, bool horizontal, T line, T* along) {
  const Vec2<T> pa = cam.project(a), pb = cam.project(b);
  const T ua = horizontal ? pa.x : pa.y, ub = horizontal ? pb.x : pb.y;  // along the axis
  const T va = horizontal ? pa.y : pa.x, vb = horizontal ? pb.y : pb.x;  // across it
  if (!((va - line) * (vb - line) <= T(0)) || va == vb) return false;
  const T lambda = (line - va) / (vb - va);
  *along = ua + lambda * (ub - ua);
  return std::isfinite(*along);
}

// Backward of edge_crossing: camera-space gradients of a and b for d(along) = g.
template <class T>
HAHA_HD void edge_crossing_backward(const CameraT<T>& cam, Vec3<T> a, Vec3<T> b, bool horizontal, T line, T g,
                                    Vec3<T>* ga, Vec3<T>* gb) {
  const Vec2<T> pa = cam.project(a), pb = cam.project(b);
  const T ua = horizontal ? pa.x : pa.y, ub = horizontal ? pb.x : pb.y;
  const T va = horizontal ? pa.y : pa.x, vb = horizontal ? pb.y : pb.x;
  const T lambda = (line - va) / (vb - va);
  const T g_ua = g * (T(1) - lambda), g_ub = g * lambda;
  const T g_va = g * (ub - ua) * (lambda - T(1)) / (vb - va), g_vb = -g * (ub - ua) * lambda / (vb - va);
  // Pixel x = fx X / Z + cx, y = fy Y / Z + cy.
  auto back = [&](Vec3<T> p, T g_u, T g_v) {
    const T gx = horizontal ? g_u : g_v, gy = horizontal ? g_v : g_u;
    const T iz = T(1) / p.z;
    return Vec3<T>(gx * cam.fx * iz, gy * cam.fy * iz, -(gx * cam.fx * p.x + gy * cam.fy * p.y) * iz * iz);
  };
  *ga = back(a, g_ua, g_va);
  *gb = back(b, g_ub, g_vb);
}

}  // namespace aa_detail

constexpr int kAaMaxWalk = 32;  // faces crossed between two pixel centres before giving up

// Coverage below which a pixel's colour is its own (M' = P' / m' is undefined at m' = 0).
template <class T>
HAHA_HD T aa_min_coverage() {
  return T(1e-6);
}

// One neighbour's partial contribution to a pixel.
template <class T>
struct AaContribution {
  T w = 0;          // weight of the neighbour's layer value in this pixel, in [0, 1/2]
  T dw_dalong = 0;  // dw / d(along) of the crossing
  int va = -1, vb = -1;  // the silhouette edge's vertex ids
  bool horizontal = true;
  T line = 0;       // row (horizontal) or column (vertical) centre of the pair
};

// Contribution of neighbour k (aa_detail::neighbour) to pixel (x, y); w = 0 when there is
// none. Both pixels of a pair reach the same occluder, edge and t.
template <class T>
HAHA_HD AaContribution<T> aa_contribution(const AntialiasInputsT<T>& in, int x, int y, int k) {
  AaContribution<T> c;
  const CameraT<T>& cam = in.camera;
  int dx, dy;
  aa_detail::neighbour(k, &dx, &dy);
  const int sx = x + dx, sy = y + dy;
  if (sx < 0 || sy < 0 || sx >= cam.width || sy >= cam.height) return c;
  const int64_t r = int64_t(y) * cam.width + x, s = int64_t(sy) * cam.width + sx;
  const int tr = in.tri[r], ts = in.tri[s];
  if (tr == ts) return c;
  bool r_occludes;
  if (tr < 0) r_occludes = false;
  else if (ts < 0) r_occludes = true;
  else if (in.depth[r] != in.depth[s]) r_occludes = in.depth[r] < in.depth[s];
  else r_occludes = tr < ts;
  const int f = r_occludes ? tr : ts;
  const bool horizontal = dy == 0;
  // Centre of the occluder's pixel along the axis, and the direction to the other pixel.
  const T centre = T(horizontal ? (r_occludes ? x : sx) : (r_occludes ? y : sy)) + T(0.5);
  const T dir = T(horizontal ? (r_occludes ? dx : -dx) : (r_occludes ? dy : -dy));
  const T line = T(horizontal ? y : x) + T(0.5);
  // Walk from the occluder's pixel along the segment: leave the current face through the
  // edge the segment crosses next; stop at a silhouette edge (found) or when the segment
  // ends inside the face. Dense meshes put a few interior edges between two pixel centres.
  int face = f, entered = -1;  // `entered`: the neighbour we came from (its shared edge is behind us)
  T t_in = T(0), best_t = T(2);
  for (int step = 0; step < kAaMaxWalk && c.va < 0; ++step) {
    const T det_f = aa_detail::face_det(cam, in.mesh, face);
    int next = -1, next_ia = -1, next_ib = -1;
    T next_t = T(2);
    bool next_silhouette = false;
    for (int i = 0; i < 3; ++i) {
      const int nb = in.neighbors[3 * face + i];
      if (nb >= 0 && nb == entered) continue;
      const int ia = in.mesh.faces[3 * face + (i + 1) % 3], ib = in.mesh.faces[3 * face + (i + 2) % 3];
      const Vec3<T> a = cam.to_camera(Vec3<T>::load(in.mesh.verts + 3 * ia));
      const Vec3<T> b = cam.to_camera(Vec3<T>::load(in.mesh.verts + 3 * ib));
      if (!(a.z >= cam.near_plane && b.z >= cam.near_plane)) continue;
      T along;
      if (!aa_detail::edge_crossing(cam, a, b, horizontal, line, &along)) continue;
      const T t = (along - centre) * dir;
      if (!(t >= t_in && t <= T(1)) || !(t < next_t)) continue;
      next_t = t;
      next = nb;
      next_ia = ia;
      next_ib = ib;
      next_silhouette = nb < 0 || (aa_detail::face_det(cam, in.mesh, nb) > T(0)) != (det_f > T(0));
    }
    if (next_ia < 0) break;  // the segment ends inside this face
    if (next_silhouette) {
      best_t = next_t;
      c.va = next_ia;
      c.vb = next_ib;
    } else {
      entered = face;
      face = next;
      t_in = next_t;
    }
  }
  if (c.va < 0) return c;
  c.horizontal = horizontal;
  c.line = line;
  if (r_occludes && best_t < T(0.5)) {
    c.w = T(0.5) - best_t;
    c.dw_dalong = -dir;
  } else if (!r_occludes && best_t > T(0.5)) {
    c.w = best_t - T(0.5);
    c.dw_dalong = dir;
  }
  return c;
}

// Row blend of pixel (x, y) of the premultiplied layer: Ph (C) and mh.
template <class T>
HAHA_HD void aa_row_blend(const AntialiasInputsT<T>& in, int x, int y, T* Ph, T* mh, AaContribution<T> c[2]) {
  const int W = in.camera.width, C = in.channels;
  const int64_t r = int64_t(y) * W + x;
  c[0] = aa_contribution(in, x, y, 0);
  c[1] = aa_contribution(in, x, y, 1);
  const T own = T(1) - c[0].w - c[1].w;
  *mh = own * in.mask[r];
  for (int ch = 0; ch < C; ++ch) Ph[ch] = own * in.mask[r] * in.color[r * C + ch];
  for (int k = 0; k < 2; ++k) {
    if (c[k].w == T(0)) continue;
    const int64_t s = r + (k == 0 ? -1 : 1);
    *mh += c[k].w * in.mask[s];
    for (int ch = 0; ch < C; ++ch) Ph[ch] += c[k].w * in.mask[s] * in.color[s * C + ch];
  }
}

// Vertical neighbours of (x, y) that take part (0: up, 1: down), with their row blends.
template <class T>
struct AaColumn {
  AaContribution<T> c[2];        // the column pair weights of (x, y)
  T Ph[3][8], mh[3];             // row blends of (x, y), up, down
  AaContribution<T> row[3][2];   // their row pair weights
};

template <class T>
HAHA_HD void aa_column(const AntialiasInputsT<T>& in, int x, int y, AaColumn<T>& col) {
  aa_row_blend(in, x, y, col.Ph[0], &col.mh[0], col.row[0]);
  for (int k = 0; k < 2; ++k) {
    col.c[k] = aa_contribution(in, x, y, 2 + k);
    if (col.c[k].w != T(0)) aa_row_blend(in, x, y + (k == 0 ? -1 : 1), col.Ph[1 + k], &col.mh[1 + k], col.row[1 + k]);
  }
}

// The column blend of the row blends: m' (ch < 0) or channel ch of P'.
template <class T>
HAHA_HD T aa_column_value(const AaColumn<T>& col, int ch) {
  T v = (T(1) - col.c[0].w - col.c[1].w) * (ch < 0 ? col.mh[0] : col.Ph[0][ch]);
  for (int k = 0; k < 2; ++k)
    if (col.c[k].w != T(0)) v += col.c[k].w * (ch < 0 ? col.mh[1 + k] : col.Ph[1 + k][ch]);
  return v;
}

// Forward of pixel (x, y): color_out (C) and mask_out.
template <class T>
HAHA_HD void antialias_pixel(const AntialiasInputsT<T>& in, int x, int y, T* color_out, T* mask_out) {
  const int C = in.channels;
  const int64_t r = int64_t(y) * in.camera.width + x;
  AaColumn<T> col;
  aa_column(in, x, y, col);
  const T m = aa_column_value(col, -1);
  for (int ch = 0; ch < C; ++ch)
    color_out[ch] = m > aa_min_coverage<T>() ? aa_column_value(col, ch) / m : in.color[r * C + ch];
  *mask_out = m;
}

// Gradient of the crossing weight c (dL/dw = gw) to the edge's world-space vertices.
template <class T, class Add>
HAHA_HD void aa_weight_backward(const AntialiasInputsT<T>& in, const AaContribution<T>& c, T gw, T* gverts, Add add) {
  if (!gverts) return;
  const CameraT<T>& cam = in.camera;
  const Vec3<T> a = cam.to_camera(Vec3<T>::load(in.mesh.verts + 3 * c.va));
  const Vec3<T> b = cam.to_camera(Vec3<T>::load(in.mesh.verts + 3 * c.vb));
  Vec3<T> ga, gb;
  aa_detail::edge_crossing_backward(cam, a, b, c.horizontal, c.line, gw * c.dw_dalong, &ga, &gb);
  const Mat3<T> Rt = transpose(cam.R);
  const Vec3<T> wa = Rt * ga, wb = Rt * gb;
  add(&gverts[3 * int64_t(c.va)], wa.x);
  add(&gverts[3 * int64_t(c.va) + 1], wa.y);
  add(&gverts[3 * int64_t(c.va) + 2], wa.z);
  add(&gverts[3 * int64_t(c.vb)], wb.x);
  add(&gverts[3 * int64_t(c.vb) + 1], wb.y);
  add(&gverts[3 * int64_t(c.vb) + 2], wb.z);
}

// Backward of aa_row_blend of pixel q for dL/dPh (gPh, C) and dL/dmh (gmh).
template <class T, class Add>
HAHA_HD void aa_row_blend_backward(const AntialiasInputsT<T>& in, int64_t q, const AaContribution<T> c[2],
                                   const T* gPh, T gmh, T* gcolor, T* gmask, T* gverts, Add add) {
  const int C = in.channels;
  // Ph = sum_j a_j m_j M_j over j in {q, q - 1, q + 1} with a = (1 - w0 - w1, w0, w1).
  auto to_layer = [&](int64_t px, T a) {
    T gm = gmh * a;
    for (int ch = 0; ch < C; ++ch) {
      if (gcolor) add(&gcolor[px * C + ch], gPh[ch] * a * in.mask[px]);
      gm += gPh[ch] * a * in.color[px * C + ch];
    }
    if (gmask) add(&gmask[px], gm);
  };
  to_layer(q, T(1) - c[0].w - c[1].w);
  for (int k = 0; k < 2; ++k) {
    if (c[k].w == T(0)) continue;
    const int64_t s = q + (k == 0 ? -1 : 1);
    to_layer(s, c[k].w);
    T gw = gmh * (in.mask[s] - in.mask[q]);
    for (int ch = 0; ch < C; ++ch)
      gw += gPh[ch] * (in.mask[s] * in.color[s * C + ch] - in.mask[q] * in.color[q * C + ch]);
    aa_weight_backward(in, c[k], gw, gverts, add);
  }
}

// Backward of pixel (x, y) for dL/dcolor_out (C) and dL/dmask_out (g_mask_out): scatter-adds
// into gcolor (P, C), gmask (P) and gverts (V, 3, world) through `add`; any may be null.
template <class T, class Add = PlainAdd>
HAHA_HD void antialias_backward_pixel(const AntialiasInputsT<T>& in, int x, int y, const T* g_color_out,
                                      T g_mask_out, T* gcolor, T* gmask, T* gverts, Add add = {}) {
  const int W = in.camera.width, C = in.channels;
  const int64_t r = int64_t(y) * W + x;
  AaColumn<T> col;
  aa_column(in, x, y, col);
  const T own = T(1) - col.c[0].w - col.c[1].w;
  const T m = aa_column_value(col, -1);
  // M' = P' / m' (or M_r below the minimum coverage): dL/dP' and dL/dm'.
  T gP[8], gm = g_mask_out;
  for (int ch = 0; ch < C; ++ch) {
    if (m > aa_min_coverage<T>()) {
      const T p = aa_column_value(col, ch);
      gP[ch] = g_color_out[ch] / m;
      gm -= g_color_out[ch] * (p / m) / m;
    } else {
      gP[ch] = T(0);
      if (gcolor) add(&gcolor[r * C + ch], g_color_out[ch]);
    }
  }
  // Column blend: P' = own Ph(r) + w_up Ph(up) + w_down Ph(down).
  T g_row[8];
  for (int ch = 0; ch < C; ++ch) g_row[ch] = gP[ch] * own;
  aa_row_blend_backward(in, r, col.row[0], g_row, gm * own, gcolor, gmask, gverts, add);
  for (int k = 0; k < 2; ++k) {
    if (col.c[k].w == T(0)) continue;
    const T w = col.c[k].w;
    for (int ch = 0; ch < C; ++ch) g_row[ch] = gP[ch] * w;
    aa_row_blend_backward(in, r + (k == 0 ? -W : W), col.row[1 + k], g_row, gm * w, gcolor, gmask, gverts, add);
    T gw = gm * (col.mh[1 + k] - col.mh[0]);
    for (int ch = 0; ch < C; ++ch) gw += gP[ch] * (col.Ph[1 + k][ch] - col.Ph[0][ch]);
    aa_weight_backward(in, col.c[k], gw, gverts, add);
  }
}

// ---------------------------------------------------------------------------------------
// CPU launchers (float and double). Throws haha::Error ("antialias: ...") for missing
// buffers or channels outside [1, 8].

// color_out (P, C) and mask_out (P) are OVERWRITTEN.
template <class T>
void antialias(const AntialiasInputsT<T>& in, NoDeduce<T>* color_out, NoDeduce<T>* mask_out);

// grad_color (P, C), grad_mask (P) and grad_verts (V, 3, world) are ACCUMULATED; any may
// be null.
template <class T>
void antialias_backward(const AntialiasInputsT<T>& in, const NoDeduce<T>* grad_color_out,
                        const NoDeduce<T>* grad_mask_out, NoDeduce<T>* grad_color, NoDeduce<T>* grad_mask,
                        NoDeduce<T>* grad_verts);

}  // namespace haha
