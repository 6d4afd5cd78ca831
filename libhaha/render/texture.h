// Bilinear texture sampling through per-pixel UVs, forward and backward (w.r.t. texels and
// w.r.t. the UVs). The per-pixel UVs come from interpolate() with attr_index = ft and
// attr = vt (mesh_raster.h): UVs are per face corner, so a pixel only ever blends the
// corners of its own face, and a UV seam (one 3D edge, two UV charts) samples each side
// from its own chart; nothing is blended across the seam in UV space.
//
// Conventions (the body model's vt, OpenGL style):
//   - texture data (H, W, C) row-major, row 0 = top of the image = v = 1, column 0 = u = 0;
//   - continuous texel coordinates x = u W - 1/2, y = (1 - v) H - 1/2, so texel (i, j) has
//     its centre at u = (i + 1/2) / W, v = 1 - (j + 1/2) / H;
//   - clamp to edge: x is clamped to [0, W - 1] and y to [0, H - 1] (an atlas must not wrap:
//     its opposite borders hold unrelated charts). Beyond the outer texel centres the border
//     value holds and the gradient w.r.t. u (v) is 0. A NaN coordinate clamps to 0.
//   - the derivative w.r.t. u, v is the one-sided (right) derivative at texel-centre lines,
//     where bilinear interpolation has a kink.
#pragma once

#include <cstdint>
#include <type_traits>

#include "core/hd.h"
#include "render/mesh_raster.h"

namespace haha {

// Borrowed texture (not owned).
template <class T>
struct TextureViewT {
  int width = 0, height = 0, channels = 0;
  const T* data = nullptr;  // (height, width, channels)
};
using TextureView = TextureViewT<float>;

// Bilinear footprint of (u, v): 4 texel indices (pixel offsets, channel 0) and weights, and
// the derivatives of the fractional coordinates w.r.t. u and v (0 where clamped).
template <class T>
struct BilinearTap {
  int64_t i00, i01, i10, i11;  // (x0,y0) (x1,y0) (x0,y1) (x1,y1), in texels
  T fx, fy;                    // fractional parts
  T dfx_du, dfy_dv;
};

template <class T>
HAHA_HD BilinearTap<T> bilinear_tap(int width, int height, T u, T v) {
  BilinearTap<T> t;
  T x = u * T(width) - T(0.5), y = (T(1) - v) * T(height) - T(0.5);
  const T xmax = T(width - 1), ymax = T(height - 1);
  t.dfx_du = (x > T(0) && x < xmax) ? T(width) : T(0);
  t.dfy_dv = (y > T(0) && y < ymax) ? -T(height) : T(0);
  x = x > T(0) ? x : T(0);  // also maps NaN to 0
  x = x < xmax ? x : xmax;
  y = y > T(0) ? y : T(0);
  y = y < ymax ? y : ymax;
  int x0 = int(x), y0 = int(y);  // x, y >= 0: truncation is floor
  if (x0 > width - 1) x0 = width - 1;
  if (y0 > height - 1) y0 = height - 1;
  const int x1 = x0 + 1 < width ? x0 + 1 : x0, y1 = y0 + 1 < height ? y0 + 1 : y0;
  t.fx = x - T(x0);
  t.fy = y - T(y0);
  t.i00 = int64_t(y0) * width + x0;
  t.i01 = int64_t(y0) * width + x1;
  t.i10 = int64_t(y1) * width + x0;
  t.i11 = int64_t(y1) * width + x1;
  return t;
}

template <class T>
HAHA_HD void bilinear_sample(const TextureViewT<T>& tex, T u, T v, T* out) {
  const BilinearTap<T> t = bilinear_tap(tex.width, tex.height, u, v);
  const int C = tex.channels;
  const T w00 = (T(1) - t.fx) * (T(1) - t.fy), w01 = t.fx * (T(1) - t.fy);
  const T w10 = (T(1) - t.fx) * t.fy, w11 = t.fx * t.fy;
  for (int c = 0; c < C; ++c)
    out[c] = w00 * tex.data[t.i00 * C + c] + w01 * tex.data[t.i01 * C + c] + w10 * tex.data[t.i10 * C + c] +
             w11 * tex.data[t.i11 * C + c];
}

// Backward of one sample: grad_tex (texels, may be null) is ACCUMULATED through `add`
// (core/hd.h; the CUDA launcher passes an atomic one), (gu, gv) written.
template <class T, class Add = PlainAdd>
HAHA_HD void bilinear_sample_backward(const TextureViewT<T>& tex, T u, T v, const T* g, T* grad_tex, T* gu,
                                      T* gv, Add add = {}) {
  const BilinearTap<T> t = bilinear_tap(tex.width, tex.height, u, v);
  const int C = tex.channels;
  const T w00 = (T(1) - t.fx) * (T(1) - t.fy), w01 = t.fx * (T(1) - t.fy);
  const T w10 = (T(1) - t.fx) * t.fy, w11 = t.fx * t.fy;
  T gfx = 0, gfy = 0;
  for (int c = 0; c < C; ++c) {
    const T a = tex.data[t.i00 * C + c], b = tex.data[t.i01 * C + c];
    const T cc = tex.data[t.i10 * C + c], d = tex.data[t.i11 * C + c];
    gfx += g[c] * ((T(1) - t.fy) * (b - a) + t.fy * (d - cc));
    gfy += g[c] * ((T(1) - t.fx) * (cc - a) + t.fx * (d - b));
    if (grad_tex) {
      add(&grad_tex[t.i00 * C + c], w00 * g[c]);
      add(&grad_tex[t.i01 * C + c], w01 * g[c]);
      add(&grad_tex[t.i10 * C + c], w10 * g[c]);
      add(&grad_tex[t.i11 * C + c], w11 * g[c]);
    }
  }
  *gu = gfx * t.dfx_du;
  *gv = gfy * t.dfy_dv;
}

// out (P, C) = bilinear sample at uv (P, 2) where tri >= 0, 0 where tri < 0 (tri may be
// null: every pixel is sampled). Throws haha::Error ("sample_texture: ...") on an empty
// texture or a null buffer.
template <class T>
void sample_texture(const TextureViewT<T>& tex, int num_pixels, const int32_t* tri, const T* uv, T* out);

// Backward: grad_texture (H, W, C) is ACCUMULATED (may be null); grad_uv (P, 2) is
// OVERWRITTEN (may be null; 0 where tri < 0).
template <class T>
void sample_texture_backward(const TextureViewT<T>& tex, int num_pixels, const int32_t* tri, const T* uv,
                             const NoDeduce<T>* grad_out, NoDeduce<T>* grad_texture,
                             NoDeduce<T>* grad_uv);

}  // namespace haha
