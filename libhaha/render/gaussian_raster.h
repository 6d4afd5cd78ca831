// Depth-conditioned Gaussian rasterizer (CPU launcher of render/gaussian_kernels.h):
// 3DGS EWA splatting into 16x16 tiles, per-tile lists sorted by camera z of the centre
// (ties by index, so results are deterministic), front-to-back compositing with early
// termination, an optional occlusion depth map and an optional per-pixel background, and
// a backward pass that replays exactly the forward that ran.
//
// Per pixel, over the Gaussians of its tile in depth order:
//   alpha_i = min(0.99, o'_i exp(-0.5 d^T conic_i d)); skipped when alpha_i < 1/255;
//   a Gaussian whose centre z > D(pixel) contributes nothing and ends the pixel (every
//   later one is at least as deep); the pixel also ends before a Gaussian that would drop
//   its transmittance below 1e-4 (that Gaussian is not composited).
//   color     = sum_i c_i alpha_i T_i                 (premultiplied, no background)
//   alpha     = 1 - T_final
//   depth     = sum_i z_i alpha_i T_i                 (NOT normalised: expected depth of the
//                                                      visible Gaussians = depth / alpha)
//   composite = color + T_final * background
// With a mesh colour M as the background image this composite is exactly the HAHA merge
// I = C_front + (1 - A) M (docs/method.md section 2), and d/d(background) is dL/dM.
//
// Buffers are caller-owned, row-major, float or double (the templates are instantiated
// for both; double exists for finite-difference tests). Images are (H, W, C) with the
// camera's width/height; N = inputs.count.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"
#include "core/camera.h"
#include "render/gaussian_kernels.h"

namespace haha {

// The Gaussians, as non-owning views. Exactly one of `colors` / `sh` must be set.
template <class T>
struct GaussianInputs {
  int count = 0;
  const T* means = nullptr;      // (N, 3) world space
  const T* quats = nullptr;      // (N, 4) (w, x, y, z), any non-zero norm (normalised inside)
  const T* scales = nullptr;     // (N, 3) linear standard deviations along the local axes
  const T* opacities = nullptr;  // (N) activated, in [0, 1]
  const T* colors = nullptr;     // (N, 3) RGB
  // Or view-dependent colour: (N, (sh_degree+1)^2, 3) coefficient-major (render/sh.h);
  // colour = max(0, SH(dir) + 0.5), dir = normalize(mean - camera centre), as in 3DGS.
  const T* sh = nullptr;
  int sh_degree = 0;
};

template <class T>
struct GaussianRasterSettings {
  bool antialiased = false;       // mip-splatting opacity compensation (else plain 0.3 dilation)
  const T* depth_map = nullptr;   // (H, W) occluder camera z; +inf = none; null = no occlusion
  const T* background = nullptr;  // (H, W, 3) per-pixel background; null = background_color
  Vec3<T> background_color{0, 0, 0};
};

// Forward outputs, caller-allocated; any may be null (not written).
template <class T>
struct GaussianRasterOutputs {
  T* color = nullptr;      // (H, W, 3) premultiplied colour of contributing Gaussians
  T* alpha = nullptr;      // (H, W) accumulated alpha = 1 - T_final
  T* depth = nullptr;      // (H, W) sum_i z_i alpha_i T_i
  T* composite = nullptr;  // (H, W, 3) color + T_final * background
};

// dL/d(outputs); null = zero.
template <class T>
struct GaussianRasterOutputGrads {
  const T* color = nullptr;
  const T* alpha = nullptr;
  const T* depth = nullptr;
  const T* composite = nullptr;
  // Not a gradient: what shows behind the Gaussians (H, W, 3) for GaussianGrads::removal_cost
  // (a merge's mesh-or-background); null = the raster's own background.
  const T* backdrop = nullptr;
};

// dL/d(inputs), caller-allocated, overwritten; null = not wanted.
template <class T>
struct GaussianGrads {
  T* means = nullptr;      // (N, 3)
  T* quats = nullptr;      // (N, 4) w.r.t. the unnormalised input quaternion
  T* scales = nullptr;     // (N, 3)
  T* opacities = nullptr;  // (N)
  T* colors = nullptr;     // (N, 3) when inputs.colors is set
  T* sh = nullptr;         // (N, K, 3) when inputs.sh is set
  T* means2d = nullptr;    // (N, 2) dL/d(screen centre) in pixels: the densification
                           // statistic (3DGS's NDC units: multiply x by W/2 and y by H/2)
  T* means2d_norm_accum = nullptr;  // (N) ACCUMULATED (+=) |(sx dL/dx, sy dL/dy)| of the screen
                                    // centre, for Gaussians with radii > 0 (3DGS densification
                                    // sum); sx, sy below: 1 gives pixels, (W/2, H/2) NDC units
  T means2d_norm_scale_x = 1, means2d_norm_scale_y = 1;
  T* background = nullptr;        // (H, W, 3) when settings.background is set
  T* background_color = nullptr;  // (3) when settings.background is null
  // Not a gradient: ACCUMULATED (+=) per Gaussian, what removing it would change in the
  // composite, sum over pixels of alpha_i T_i |c_i - behind_i| (mean over channels; behind_i:
  // the colour of what lies behind it there, the backdrop included). Exact: deleting Gaussian
  // i alone changes each pixel by alpha_i T_i (c_i - behind_i). Units: pixels fully changed.
  T* removal_cost = nullptr;  // (N)
};

// What the forward leaves for the backward (and for densification), reused across calls
// so that steady-state rendering allocates nothing. Callers read `radii` / visible() /
// pairs(); the rest is the rasterizer's own. Memory: ~12 bytes per (Gaussian, tile) pair
// after the forward, +10 scalars per pair during the backward.
template <class T>
struct GaussianRasterState {
  int width = 0, height = 0, tiles_x = 0, tiles_y = 0, count = 0;
  std::vector<int32_t> radii;                      // (N) footprint half-size in pixels (ceil); 0 =
                                                   // culled, off-screen or occluded everywhere
  std::vector<gs::ProjectedGaussian<T>> proj;      // (N) valid where radii > 0
  std::vector<uint8_t> color_clamped;              // (N, 3) SH colour clamped at 0 (zero grad)
  std::vector<uint32_t> order;                     // visible Gaussians sorted by (z, index)
  std::vector<uint32_t> tile_offsets;              // (tiles + 1) into tile_list
  std::vector<uint32_t> tile_list;                 // Gaussian indices, per tile in depth order
  std::vector<uint32_t> pair_offsets;              // (N + 1) into pair_slots, by Gaussian index
  std::vector<uint32_t> pair_slots;                // tile_list positions of each Gaussian's pairs
  std::vector<T> tile_max_depth;                   // (tiles) max of the depth map per tile
  std::vector<T> final_t;                          // (H, W) final transmittance
  std::vector<int32_t> last;                       // (H, W) tile_list position of the last
                                                   // contributor, -1 = none
  std::vector<T> pair_grad;                        // backward scratch, 10 per pair
  std::vector<uint32_t> scratch_u32;               // binning scratch
  bool visible(int i) const { return radii[size_t(i)] > 0; }
  int64_t pairs() const { return tile_offsets.empty() ? 0 : int64_t(tile_offsets.back()); }
};

// Forward. Throws haha::Error for inconsistent inputs (missing buffers, bad camera size).
template <class T>
void rasterize_gaussians(const GaussianInputs<T>& in, const CameraT<T>& cam, const GaussianRasterSettings<T>& settings,
                         GaussianRasterState<T>& state, const GaussianRasterOutputs<T>& out);

// Backward of the forward that filled `state` (same inputs, camera and settings; the
// forward's outputs are not needed). Can be called more than once per forward.
template <class T>
void rasterize_gaussians_backward(const GaussianInputs<T>& in, const CameraT<T>& cam,
                                  const GaussianRasterSettings<T>& settings, GaussianRasterState<T>& state,
                                  const GaussianRasterOutputGrads<T>& dout, const GaussianGrads<T>& grads);

}  // namespace haha
