// The per-pixel compositing steps and the per-Gaussian pieces of the Gaussian rasterizer
// (render/gaussian_raster.h), as HAHA_HD functions shared by the CPU launcher
// (gaussian_raster.cpp) and the CUDA launcher (cuda/gaussian_raster_cuda.cu). The launchers
// differ only in how they walk tiles and reduce sums; what happens at one pixel for one
// Gaussian, and to one Gaussian from its summed screen-space gradient, is written here once.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/hd.h"
#include "core/math.h"
#include "core/camera.h"
#include "render/gaussian_kernels.h"
#include "render/gaussian_raster.h"
#include "render/sh.h"

namespace haha::gs {

// Per-(Gaussian, tile) gradient slots: mx, my, ca, cb, cc, opacity, z, r, g, b, and the
// removal cost (GaussianGrads::removal_cost).
inline constexpr int kGradSlots = 11;

// Inclusive tile range of a projected Gaussian's pixel box.
struct TileRect {
  int x0, y0, x1, y1;
};
template <class T>
HAHA_HD TileRect tile_rect(const ProjectedGaussian<T>& p) {
  return {p.x0 / kTileSize, p.y0 / kTileSize, p.x1 / kTileSize, p.y1 / kTileSize};
}

// Occluder depth of a tile = fold of this over its pixels from -inf: the maximum, and
// +inf as soon as one pixel is NaN (then nothing in the tile may be culled). Order-free,
// so a parallel reduction gives the serial result.
template <class T>
HAHA_HD T tile_depth_fold(T m, T d) {
  return d != d ? T(INFINITY) : (m < d ? d : m);
}

// Whether a (Gaussian, tile) pair survives the occlusion cull.
template <class T>
HAHA_HD bool pair_visible(const ProjectedGaussian<T>& p, bool has_depth, T tile_max_depth) {
  return !has_depth || p.z <= tile_max_depth;
}

template <class T>
HAHA_HD Vec3<T> camera_center(const CameraT<T>& cam) {
  return -(transpose(cam.R) * cam.t);
}

// Colour of Gaussian i as the rasterizer composites it; `clamped` marks SH channels cut at 0.
template <class T>
HAHA_HD Vec3<T> gaussian_color(const GaussianInputs<T>& in, Vec3<T> cam_center, int64_t i, uint8_t* clamped) {
  if (in.colors) return Vec3<T>::load(in.colors + 3 * i);
  const Vec3<T> dir_raw = Vec3<T>::load(in.means + 3 * i) - cam_center;
  const Vec3<T> dir = dir_raw / norm(dir_raw);
  Vec3<T> c = eval_sh(in.sh_degree, in.sh + i * 3 * sh_coeff_count(in.sh_degree), dir);
  for (int k = 0; k < 3; ++k) {
    c[k] += T(0.5);
    clamped[k] = c[k] < 0;
    if (clamped[k]) c[k] = 0;
  }
  return c;
}

// Front-to-back step of Gaussian g (at tile-list position pos) at the pixel centre
// (px, py), inside g's pixel box, of a pixel that has not ended. Updates the pixel's
// transmittance, colour, depth and last contributor. Returns true when the pixel ends
// here: g lies behind the occluder (so does every later Gaussian), or compositing g would
// drop the transmittance below kTransmittanceMin (g is then not composited).
template <class T>
HAHA_HD bool composite_step(const ProjectedGaussian<T>& g, T px, T py, T occluder, int32_t pos, T& trans, T* col,
                            T& dep, int32_t& last) {
  if (g.z > occluder) return true;
  T dx, dy, gauss;
  bool clamped;
  const T alpha = pixel_alpha(g, px, py, dx, dy, gauss, clamped);
  if (alpha == 0) return false;
  const T next = trans * (1 - alpha);
  if (next < T(kTransmittanceMin)) return true;
  const T w = alpha * trans;
  col[0] += w * g.color[0];
  col[1] += w * g.color[1];
  col[2] += w * g.color[2];
  dep += w * g.z;
  trans = next;
  last = pos;
  return false;
}

// Back-to-front step of the backward pass for a Gaussian the forward composited at this
// pixel or skipped there (positions <= the pixel's last contributor, inside g's box).
// trans walks back from T_final (tfin); behind / behind_z are the colour and depth of the
// Gaussians behind g already visited; d_col (3), d_dep, d_tf are dL/d(colour, depth,
// T_final) of the pixel. Adds g's screen-space gradient to acc and its colour gradient to
// acc_col (3). With backdrop_t (3: T_final times what shows behind every Gaussian), adds
// what removing g changes at this pixel to acc_cost: alpha T_i (c - behind normalised) =
// w c - alpha (behind + backdrop_t) / (1 - alpha), mean |.| over the channels.
template <class T>
HAHA_HD void composite_step_backward(const ProjectedGaussian<T>& g, T px, T py, T& trans, T tfin, T* behind,
                                     T& behind_z, const T* d_col, T d_dep, T d_tf, ProjectedGrad<T>& acc,
                                     T* acc_col, const T* backdrop_t = nullptr, T* acc_cost = nullptr) {
  T dx, dy, gauss;
  bool clamped;
  const T alpha = pixel_alpha(g, px, py, dx, dy, gauss, clamped);
  if (alpha == 0) return;
  const T one_minus = 1 - alpha;
  const T t_i = trans / one_minus;  // transmittance in front of this Gaussian
  const T w = alpha * t_i;
  if (backdrop_t) {
    T cost = 0;
    for (int c = 0; c < 3; ++c) {
      const T change = w * g.color[c] - alpha * (behind[c] + backdrop_t[c]) / one_minus;
      cost += change < 0 ? -change : change;
    }
    *acc_cost += cost / 3;
  }
  T d_alpha = 0;
  for (int c = 0; c < 3; ++c) {
    d_alpha += d_col[c] * (g.color[c] * t_i - behind[c] / one_minus);
    acc_col[c] += d_col[c] * w;
  }
  d_alpha += d_dep * (g.z * t_i - behind_z / one_minus);
  d_alpha -= d_tf * tfin / one_minus;
  acc.z += d_dep * w;
  for (int c = 0; c < 3; ++c) behind[c] += g.color[c] * w;
  behind_z += g.z * w;
  trans = t_i;
  pixel_alpha_backward(g, dx, dy, gauss, clamped, d_alpha, acc);
}

// Upstream gradients of one pixel: dL/dcolour (3, colour + composite), dL/ddepth and
// dL/dT_final (composite's background term minus dL/dalpha).
template <class T>
HAHA_HD void pixel_upstream(const GaussianRasterSettings<T>& s, const GaussianRasterOutputGrads<T>& dout, int64_t pix,
                            T* d_col, T& d_dep, T& d_tf) {
  T dtf = 0;
  for (int c = 0; c < 3; ++c) {
    const T dc = (dout.color ? dout.color[3 * pix + c] : T(0));
    const T dcomp = (dout.composite ? dout.composite[3 * pix + c] : T(0));
    d_col[c] = dc + dcomp;
    dtf += dcomp * (s.background ? s.background[3 * pix + c] : s.background_color[c]);
  }
  if (dout.alpha) dtf -= dout.alpha[pix];
  d_tf = dtf;
  d_dep = dout.depth ? dout.depth[pix] : T(0);
}

// T_final times what shows behind every Gaussian at pixel pix (for the removal cost):
// dout.backdrop, else the raster's background.
template <class T>
HAHA_HD void pixel_backdrop(const GaussianRasterSettings<T>& s, const GaussianRasterOutputGrads<T>& dout, int64_t pix,
                            T tfin, T* out) {
  for (int c = 0; c < 3; ++c)
    out[c] = tfin * (dout.backdrop ? dout.backdrop[3 * pix + c]
                                   : (s.background ? s.background[3 * pix + c] : s.background_color[c]));
}

// Gaussian i's input gradients from its summed gradient slots (sum, kGradSlots values):
// chains through the projection (recomputed) and the SH colour, OVERWRITES the per-Gaussian
// outputs of `grads` (zeros for an invisible Gaussian) and ADDS to means2d_norm_accum.
// clamped: the forward's SH clamp flags (3).
template <class T>
HAHA_HD void gaussian_backward_one(const GaussianInputs<T>& in, const CameraT<T>& cam, bool antialiased,
                                   Vec3<T> center, int64_t i, bool visible, const uint8_t* clamped, const T* sum,
                                   const GaussianGrads<T>& grads) {
  const int ksh = in.sh ? sh_coeff_count(in.sh_degree) : 0;
  T* d_mean = grads.means ? grads.means + 3 * i : nullptr;
  T* d_quat = grads.quats ? grads.quats + 4 * i : nullptr;
  T* d_scale = grads.scales ? grads.scales + 3 * i : nullptr;
  T* d_opac = grads.opacities ? grads.opacities + i : nullptr;
  T* d_color = (grads.colors && in.colors) ? grads.colors + 3 * i : nullptr;
  T* d_sh = (grads.sh && in.sh) ? grads.sh + i * 3 * ksh : nullptr;
  T* d_m2 = grads.means2d ? grads.means2d + 2 * i : nullptr;
  if (!visible) {
    for (int k = 0; k < 3; ++k) {
      if (d_mean) d_mean[k] = 0;
      if (d_scale) d_scale[k] = 0;
      if (d_color) d_color[k] = 0;
    }
    for (int k = 0; k < 4; ++k)
      if (d_quat) d_quat[k] = 0;
    if (d_opac) *d_opac = 0;
    for (int k = 0; k < 3 * ksh; ++k)
      if (d_sh) d_sh[k] = 0;
    if (d_m2) d_m2[0] = d_m2[1] = 0;
    return;
  }
  ProjectedGrad<T> pg;
  pg.mx = sum[0];
  pg.my = sum[1];
  pg.ca = sum[2];
  pg.cb = sum[3];
  pg.cc = sum[4];
  pg.opacity = sum[5];
  pg.z = sum[6];
  if (d_m2) d_m2[0] = pg.mx, d_m2[1] = pg.my;
  if (grads.means2d_norm_accum) {
    const T sx = grads.means2d_norm_scale_x * pg.mx, sy = grads.means2d_norm_scale_y * pg.my;
    grads.means2d_norm_accum[i] += std::sqrt(sx * sx + sy * sy);
  }
  ProjectedGaussian<T> proj;
  ProjectionCache<T> cache;
  project_gaussian(cam, in.means + 3 * i, in.quats + 4 * i, in.scales + 3 * i, in.opacities[i], antialiased, proj,
                   cache);
  T dm[3], dq[4], ds[3], dop;
  project_gaussian_backward(cam, in.scales + 3 * i, in.opacities[i], antialiased, cache, pg, dm, dq, ds, &dop);
  if (in.colors) {
    if (d_color) d_color[0] = sum[7], d_color[1] = sum[8], d_color[2] = sum[9];
  } else {
    // colour = max(0, SH(dir) + 0.5), dir = (mean - centre) / |mean - centre|.
    Vec3<T> dcol;
    for (int c = 0; c < 3; ++c) dcol[c] = clamped[c] ? T(0) : sum[7 + c];
    T local_sh[3 * 16] = {};
    const Vec3<T> dir_raw = Vec3<T>::load(in.means + 3 * i) - center;
    const T len = norm(dir_raw);
    const Vec3<T> dir = dir_raw / len;
    const Vec3<T> d_dir = eval_sh_backward(in.sh_degree, in.sh + i * 3 * ksh, dir, dcol, local_sh);
    const Vec3<T> d_raw = (d_dir - dot(dir, d_dir) * dir) / len;
    dm[0] += d_raw.x;
    dm[1] += d_raw.y;
    dm[2] += d_raw.z;
    if (d_sh)
      for (int k = 0; k < 3 * ksh; ++k) d_sh[k] = local_sh[k];
  }
  if (d_mean)
    for (int k = 0; k < 3; ++k) d_mean[k] = dm[k];
  if (d_quat)
    for (int k = 0; k < 4; ++k) d_quat[k] = dq[k];
  if (d_scale)
    for (int k = 0; k < 3; ++k) d_scale[k] = ds[k];
  if (d_opac) *d_opac = dop;
  if (grads.removal_cost) grads.removal_cost[i] += sum[10];
}

}  // namespace haha::gs
