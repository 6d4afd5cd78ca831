// Merge of the Gaussian layer in front of the mesh with the mesh and the background
// (docs/method.md section 2), forward and backward:
//
//     I = C_front + (1 - A) * (m * M + (1 - m) * B)
//
// C_front: premultiplied colour of the Gaussians in front of the mesh, A: their accumulated
// alpha (from the Gaussian rasterizer run with the mesh depth as occlusion map and with NO
// background of its own, i.e. background 0: the background enters here exactly once),
// M: mesh colour (from the texture), m: mesh silhouette in [0, 1] (the rasterizer's binary
// mask; a soft mask works too), B: per-pixel background image or one colour.
// Inside the mesh (m = 1) I = C_front + (1 - A) M; elsewhere I = C_front + (1 - A) B.
// The mesh colour enters once; the background gradient is per pixel (no "first pixel").
#pragma once

#include <cstdint>

#include "core/hd.h"

namespace haha {

template <class T>
struct MergeInputsT {
  int num_pixels = 0;
  const T* color_front = nullptr;  // (P, 3); null = no Gaussians (C_front = 0)
  const T* alpha = nullptr;        // (P);    null = no Gaussians (A = 0)
  const T* mesh_color = nullptr;   // (P, 3) M; needed when mesh_mask is set
  const T* mesh_mask = nullptr;    // (P) m in [0, 1]; null = no mesh (m = 0)
  const T* background = nullptr;   // (P, 3) per-pixel background; null = background_color
  T background_color[3] = {T(0), T(0), T(0)};
};

// Gradient outputs; any may be null. Per-pixel ones are OVERWRITTEN; background_color (3) is
// ACCUMULATED (summed over pixels; it receives nothing when a per-pixel background is used).
template <class T>
struct MergeGradsT {
  T* color_front = nullptr;       // (P, 3)
  T* alpha = nullptr;             // (P)
  T* mesh_color = nullptr;        // (P, 3)
  T* mesh_mask = nullptr;         // (P)
  T* background = nullptr;        // (P, 3)
  T* background_color = nullptr;  // (3)
  // Not a gradient: the colour behind the Gaussians, U = m M + (1 - m) B (P, 3), for the
  // rasterizer's removal cost (GaussianRasterOutputGrads::backdrop).
  T* under = nullptr;
};

using MergeInputs = MergeInputsT<float>;
using MergeGrads = MergeGradsT<float>;

// out (P, 3) is OVERWRITTEN. Throws haha::Error ("merge: ...") when mesh_mask is given
// without mesh_color or num_pixels < 0.
template <class T>
void merge(const MergeInputsT<T>& in, T* out);

template <class T>
void merge_backward(const MergeInputsT<T>& in, const T* grad_out, const MergeGradsT<T>& grads);

// Kernel of one pixel: the colour behind the Gaussians, U = m M + (1 - m) B.
template <class T>
HAHA_HD void merge_under(const MergeInputsT<T>& in, int64_t p, T under[3]) {
  const T m = in.mesh_mask ? in.mesh_mask[p] : T(0);
  const T* B = in.background ? in.background + 3 * p : in.background_color;
  for (int c = 0; c < 3; ++c) under[c] = (m != T(0) ? m * in.mesh_color[3 * p + c] : T(0)) + (T(1) - m) * B[c];
}

// Kernel of merge for pixel p.
template <class T>
HAHA_HD void merge_pixel(const MergeInputsT<T>& in, int64_t p, T* out) {
  T under[3];
  merge_under(in, p, under);
  const T A = in.alpha ? in.alpha[p] : T(0);
  for (int c = 0; c < 3; ++c) out[3 * p + c] = (in.color_front ? in.color_front[3 * p + c] : T(0)) + (T(1) - A) * under[c];
}

// Kernel of merge_backward for pixel p; the background-colour gradient goes to gbg (3,
// accumulated) when bg_colour is set.
template <class T>
HAHA_HD void merge_backward_pixel(const MergeInputsT<T>& in, int64_t p, const T* grad_out, const MergeGradsT<T>& grads,
                                  bool bg_colour, T* gbg) {
  const T* g = grad_out + 3 * p;
  const T A = in.alpha ? in.alpha[p] : T(0);
  const T m = in.mesh_mask ? in.mesh_mask[p] : T(0);
  const T* B = in.background ? in.background + 3 * p : in.background_color;
  T under[3];
  merge_under(in, p, under);
  if (grads.color_front)
    for (int c = 0; c < 3; ++c) grads.color_front[3 * p + c] = g[c];
  if (grads.under)
    for (int c = 0; c < 3; ++c) grads.under[3 * p + c] = under[c];
  if (grads.alpha) grads.alpha[p] = -(g[0] * under[0] + g[1] * under[1] + g[2] * under[2]);
  if (grads.mesh_color)
    for (int c = 0; c < 3; ++c) grads.mesh_color[3 * p + c] = (T(1) - A) * m * g[c];
  if (grads.mesh_mask) {
    T s = 0;
    if (in.mesh_mask)
      for (int c = 0; c < 3; ++c) s += g[c] * (in.mesh_color[3 * p + c] - B[c]);
    grads.mesh_mask[p] = (T(1) - A) * s;
  }
  if (grads.background)
    for (int c = 0; c < 3; ++c) grads.background[3 * p + c] = in.background ? (T(1) - A) * (T(1) - m) * g[c] : T(0);
  if (bg_colour)
    for (int c = 0; c < 3; ++c) gbg[c] += (T(1) - A) * (T(1) - m) * g[c];
}

}  // namespace haha
