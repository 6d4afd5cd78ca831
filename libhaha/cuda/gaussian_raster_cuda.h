// Depth-conditioned Gaussian rasterizer on the GPU, with the CPU path's semantics
// (render/gaussian_raster.h) and maths (render/gaussian_kernels.h,
// render/gaussian_composite.h):
//   1. project: one thread per Gaussian (footprint, colour, tiles it reaches that are not
//      wholly behind the occluder);
//   2. bin: one (tile << 32 | depth bits) key per surviving (Gaussian, tile) pair, emitted
//      in Gaussian order, then a stable cub radix sort: every tile's list comes out in
//      (depth, index) order, exactly the CPU's lists;
//   3. render: one 16 x 16 block per tile, Gaussians fetched into shared memory in
//      batches, front to back with the same per-pixel step and early termination;
//   backward: the same tiles back to front; each Gaussian's per-pixel gradients are
//   summed over the warp, then added atomically (sums are order-dependent in float), and
//   one thread per Gaussian chains them through the projection and the colour.
// Inputs, settings, outputs and gradients are the CPU structs with DEVICE pointers; the
// camera is passed by value. Reading the pair count back (to size the sort) synchronises
// once per forward.
#pragma once

#include <cstdint>

#include "core/camera.h"
#include "render/gaussian_kernels.h"
#include "render/gaussian_raster.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// What the forward leaves for the backward; reused between calls (grows, never shrinks).
struct GaussianRasterCudaState {
  int width = 0, height = 0, tiles_x = 0, tiles_y = 0, count = 0;
  int64_t num_pairs = 0;
  bool has_depth = false;
  DeviceBuffer<int32_t> radii;                       // (N) 0 = culled / occluded everywhere
  DeviceBuffer<gs::ProjectedGaussian<float>> proj;   // (N)
  DeviceBuffer<uint8_t> color_clamped;               // (N, 3)
  DeviceBuffer<uint32_t> pair_count, pair_offset;    // (N) pairs per Gaussian, exclusive scan
  DeviceBuffer<uint64_t> keys, keys_sorted;          // (pairs)
  DeviceBuffer<uint32_t> values, tile_list;          // (pairs) Gaussian index, sorted
  DeviceBuffer<uint32_t> tile_range;                 // (tiles, 2) [begin, end) into tile_list
  DeviceBuffer<float> tile_max_depth;                // (tiles)
  DeviceBuffer<float> final_t;                       // (H, W)
  DeviceBuffer<int32_t> last;                        // (H, W) tile_list position, -1 = none
  DeviceBuffer<float> grad_sum;                      // (N, 10) backward sums
  DeviceBuffer<uint8_t> temp;                        // cub scratch
};

// Forward (GaussianRasterSettings: depth_map (H, W), background (H, W, 3) device or null).
// Throws haha::Error for inconsistent inputs, as the CPU path.
void rasterize_gaussians_cuda(const GaussianInputs<float>& in, const Camera& cam,
                              const GaussianRasterSettings<float>& settings, GaussianRasterCudaState& state,
                              const GaussianRasterOutputs<float>& out);

// Backward of the forward that filled `state`; gradient buffers as GaussianGrads (device;
// per-Gaussian ones overwritten, means2d_norm_accum and nothing else accumulated;
// background_color (3) written).
void rasterize_gaussians_backward_cuda(const GaussianInputs<float>& in, const Camera& cam,
                                       const GaussianRasterSettings<float>& settings, GaussianRasterCudaState& state,
                                       const GaussianRasterOutputGrads<float>& dout, const GaussianGrads<float>& grads);

// Host convenience (render-ply, benchmarks): uploads host inputs, renders the composite
// over settings.background_color (no depth map, no per-pixel background), downloads
// (H, W, 3).
std::vector<float> render_gaussians_image_cuda(const GaussianInputs<float>& host_inputs, const Camera& cam,
                                               Vec3f background, bool antialiased);

// gs::pixel_alpha (and its exponent gs::pixel_power) of n (Gaussian, pixel centre) pairs,
// for the parity test of the per-pixel cut decisions (tests/cuda/trainer_test.cpp): the
// forward and backward kernels evaluate exactly this. All pointers device (n each);
// clamped[i] = alpha hit kAlphaMax.
void pixel_alpha_cuda(const gs::ProjectedGaussian<float>* g, const float* px, const float* py, int n, float* alpha,
                      float* power, uint8_t* clamped);

}  // namespace haha::cuda
