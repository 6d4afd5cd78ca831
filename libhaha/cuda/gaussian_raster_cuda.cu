#include "cuda/gaussian_raster_cuda.h"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

#include "cuda/device_util.cuh"
#include "render/gaussian_composite.h"
#include "render/sh.h"

namespace haha::cuda {

namespace {

using gs::kTileSize;
constexpr int kTilePixels = kTileSize * kTileSize;  // one thread per pixel of a tile
constexpr int kSlots = gs::kGradSlots;
using Proj = gs::ProjectedGaussian<float>;

void validate(const GaussianInputs<float>& in, const Camera& cam, const char* where) {
  if (cam.width <= 0 || cam.height <= 0) fail(where, "camera has no pixels");
  if (!(cam.fx > 0) || !(cam.fy > 0)) fail(where, "camera focal lengths must be positive");
  if (in.count < 0) fail(where, "negative Gaussian count");
  if (in.count == 0) return;
  if (!in.means || !in.quats || !in.scales || !in.opacities) fail(where, "missing Gaussian buffer");
  if ((in.colors == nullptr) == (in.sh == nullptr)) fail(where, "exactly one of colors / sh must be given");
  if (in.sh && (in.sh_degree < 0 || in.sh_degree > kMaxShDegree)) fail(where, "sh_degree must be 0..3");
}

__global__ void tile_max_depth_kernel(const float* depth, int W, int H, int tiles_x, float* out) {
  __shared__ float part[kTilePixels];
  const int t = blockIdx.x, tx = t % tiles_x, ty = t / tiles_x;
  const int x = tx * kTileSize + int(threadIdx.x) % kTileSize, y = ty * kTileSize + int(threadIdx.x) / kTileSize;
  float m = -INFINITY;
  if (x < W && y < H) m = gs::tile_depth_fold(m, depth[int64_t(y) * W + x]);
  part[threadIdx.x] = m;
  __syncthreads();
  // Partial results are never NaN (a NaN pixel became +inf), so the fold is a plain max.
  for (int s = kTilePixels / 2; s > 0; s >>= 1) {
    if (int(threadIdx.x) < s) part[threadIdx.x] = gs::tile_depth_fold(part[threadIdx.x], part[threadIdx.x + s]);
    __syncthreads();
  }
  if (threadIdx.x == 0) out[t] = part[0];
}

__global__ void project_kernel(GaussianInputs<float> in, Camera cam, bool antialiased, Vec3f center, int tiles_x,
                               bool has_depth, const float* tmax, Proj* proj, int32_t* radii, uint8_t* clamped,
                               uint32_t* pair_count) {
  const int64_t i = detail::global_index();
  if (i >= in.count) return;
  radii[i] = 0;
  pair_count[i] = 0;
  gs::ProjectionCache<float> cache;
  Proj p;
  if (!gs::project_gaussian(cam, in.means + 3 * i, in.quats + 4 * i, in.scales + 3 * i, in.opacities[i], antialiased,
                            p, cache))
    return;
  const Vec3f c = gs::gaussian_color(in, center, i, clamped + 3 * i);
  p.color[0] = c.x;
  p.color[1] = c.y;
  p.color[2] = c.z;
  proj[i] = p;
  const gs::TileRect r = gs::tile_rect(p);
  uint32_t n = 0;
  for (int ty = r.y0; ty <= r.y1; ++ty)
    for (int tx = r.x0; tx <= r.x1; ++tx) n += gs::pair_visible(p, has_depth, has_depth ? tmax[ty * tiles_x + tx] : 0.0f);
  pair_count[i] = n;
  // Occluded everywhere it reaches counts as culled.
  if (n > 0) radii[i] = int32_t(ceilf(fminf(cache.radius, 1e9f)));
}

__global__ void emit_pairs_kernel(int n, const Proj* proj, const int32_t* radii, const uint32_t* pair_count,
                                  const uint32_t* pair_incl, int tiles_x, bool has_depth, const float* tmax,
                                  uint64_t* keys, uint32_t* values) {
  const int i = int(detail::global_index());
  if (i >= n || radii[i] <= 0) return;
  const Proj& p = proj[i];
  uint32_t slot = pair_incl[i] - pair_count[i];
  const uint32_t zbits = __float_as_uint(p.z);  // z > near > 0: positive floats order like their bits
  const gs::TileRect r = gs::tile_rect(p);
  for (int ty = r.y0; ty <= r.y1; ++ty)
    for (int tx = r.x0; tx <= r.x1; ++tx) {
      const int t = ty * tiles_x + tx;
      if (!gs::pair_visible(p, has_depth, has_depth ? tmax[t] : 0.0f)) continue;
      keys[slot] = (uint64_t(t) << 32) | zbits;
      values[slot] = uint32_t(i);
      ++slot;
    }
}

__global__ void tile_range_kernel(int64_t pairs, const uint64_t* keys, uint32_t* range) {
  const int64_t k = detail::global_index();
  if (k >= pairs) return;
  const uint32_t t = uint32_t(keys[k] >> 32);
  if (k == 0 || uint32_t(keys[k - 1] >> 32) != t) range[2 * t] = uint32_t(k);
  if (k == pairs - 1 || uint32_t(keys[k + 1] >> 32) != t) range[2 * t + 1] = uint32_t(k + 1);
}

struct RenderArgs {
  int W, H, tiles_x;
  const uint32_t* range;
  const uint32_t* list;
  const Proj* proj;
  const float* depth_map;
  const float* background;
  Vec3f background_color;
  GaussianRasterOutputs<float> out;
  float* final_t;
  int32_t* last;
};

__device__ __forceinline__ bool in_box(const Proj& g, int x, int y) {
  return x >= g.x0 && x <= g.x1 && y >= g.y0 && y <= g.y1;
}

__global__ void __launch_bounds__(kTilePixels) render_kernel(RenderArgs a) {
  __shared__ Proj batch[kTilePixels];
  const int t = blockIdx.x, tx = t % a.tiles_x, ty = t / a.tiles_x;
  const int x = tx * kTileSize + int(threadIdx.x) % kTileSize, y = ty * kTileSize + int(threadIdx.x) / kTileSize;
  const bool inside = x < a.W && y < a.H;
  const int64_t pix = int64_t(y) * a.W + x;
  const float occluder = (inside && a.depth_map) ? a.depth_map[pix] : INFINITY;
  const float px = float(x) + 0.5f, py = float(y) + 0.5f;
  bool done = !inside;
  float trans = 1.0f, col[3] = {0.0f, 0.0f, 0.0f}, dep = 0.0f;
  int32_t last = -1;
  const uint32_t begin = a.range[2 * t], end = a.range[2 * t + 1];
  for (uint32_t base = begin; base < end; base += kTilePixels) {
    if (__syncthreads_count(done) == kTilePixels) break;
    const uint32_t k = base + threadIdx.x;
    if (k < end) batch[threadIdx.x] = a.proj[a.list[k]];
    __syncthreads();
    const int nb = int(min(uint32_t(kTilePixels), end - base));
    for (int j = 0; j < nb && !done; ++j) {
      const Proj& g = batch[j];
      if (!in_box(g, x, y)) continue;
      done = gs::composite_step(g, px, py, occluder, int32_t(base + j), trans, col, dep, last);
    }
  }
  if (!inside) return;
  a.final_t[pix] = trans;
  a.last[pix] = last;
  if (a.out.color)
    for (int c = 0; c < 3; ++c) a.out.color[3 * pix + c] = col[c];
  if (a.out.alpha) a.out.alpha[pix] = 1 - trans;
  if (a.out.depth) a.out.depth[pix] = dep;
  if (a.out.composite)
    for (int c = 0; c < 3; ++c)
      a.out.composite[3 * pix + c] =
          col[c] + trans * (a.background ? a.background[3 * pix + c] : a.background_color[c]);
}

struct BackwardArgs {
  int W, H, tiles_x;
  const uint32_t* range;
  const uint32_t* list;
  const Proj* proj;
  const float* final_t;
  const int32_t* last;
  GaussianRasterSettings<float> settings;
  GaussianRasterOutputGrads<float> dout;
  bool cost;        // GaussianGrads::removal_cost wanted
  float* grad_sum;  // (N, kSlots)
};

__global__ void __launch_bounds__(kTilePixels) render_backward_kernel(BackwardArgs a) {
  __shared__ Proj batch[kTilePixels];
  __shared__ uint32_t batch_id[kTilePixels];
  __shared__ int max_last;
  const int t = blockIdx.x, tx = t % a.tiles_x, ty = t / a.tiles_x;
  const int x = tx * kTileSize + int(threadIdx.x) % kTileSize, y = ty * kTileSize + int(threadIdx.x) / kTileSize;
  const bool inside = x < a.W && y < a.H;
  const int64_t pix = int64_t(y) * a.W + x;
  const float px = float(x) + 0.5f, py = float(y) + 0.5f;
  const uint32_t begin = a.range[2 * t];
  int32_t last = -1;
  float trans = 1.0f, tfin = 1.0f, behind[3] = {0.0f, 0.0f, 0.0f}, behind_z = 0.0f;
  float d_col[3] = {0.0f, 0.0f, 0.0f}, d_dep = 0.0f, d_tf = 0.0f;
  float backdrop_t[3] = {0.0f, 0.0f, 0.0f};  // removal cost only
  if (inside) {
    last = a.last[pix];
    trans = tfin = a.final_t[pix];
    gs::pixel_upstream(a.settings, a.dout, pix, d_col, d_dep, d_tf);
    if (a.cost) gs::pixel_backdrop(a.settings, a.dout, pix, tfin, backdrop_t);
  }
  if (threadIdx.x == 0) max_last = int(begin) - 1;
  __syncthreads();
  atomicMax(&max_last, int(last));
  __syncthreads();
  const int lane = int(threadIdx.x) & 31;
  for (int hi = max_last; hi >= int(begin); hi -= kTilePixels) {
    const int lo = max(int(begin), hi - kTilePixels + 1);
    const int pos = hi - int(threadIdx.x);
    __syncthreads();  // the previous batch is no longer read
    if (pos >= lo) {
      const uint32_t id = a.list[pos];
      batch_id[threadIdx.x] = id;
      batch[threadIdx.x] = a.proj[id];
    }
    __syncthreads();
    for (int j = 0; j < hi - lo + 1; ++j) {
      const Proj& g = batch[j];
      const bool mine = inside && hi - j <= last && in_box(g, x, y);
      if (!__any_sync(0xffffffffu, mine)) continue;
      gs::ProjectedGrad<float> acc;
      float acc_col[3] = {0.0f, 0.0f, 0.0f}, acc_cost = 0.0f;
      if (mine)
        gs::composite_step_backward(g, px, py, trans, tfin, behind, behind_z, d_col, d_dep, d_tf, acc, acc_col,
                                    a.cost ? backdrop_t : nullptr, &acc_cost);
      float v[kSlots] = {acc.mx,    acc.my,    acc.ca,    acc.cb,    acc.cc,   acc.opacity,
                         acc.z,     acc_col[0], acc_col[1], acc_col[2], acc_cost};
#pragma unroll
      for (int s = 0; s < kSlots; ++s) v[s] = detail::warp_sum(v[s]);
      if (lane == 0) {
        float* dst = a.grad_sum + size_t(batch_id[j]) * kSlots;
#pragma unroll
        for (int s = 0; s < kSlots; ++s)
          if (v[s] != 0.0f) atomicAdd(dst + s, v[s]);
      }
    }
  }
}

__global__ void gaussian_backward_kernel(GaussianInputs<float> in, Camera cam, bool antialiased, Vec3f center,
                                         const int32_t* radii, const uint8_t* clamped, const float* grad_sum,
                                         GaussianGrads<float> grads) {
  const int64_t i = detail::global_index();
  if (i >= in.count) return;
  const bool visible = radii[i] > 0;
  float sum[kSlots] = {};
  if (visible)
    for (int s = 0; s < kSlots; ++s) sum[s] = grad_sum[i * kSlots + s];
  gs::gaussian_backward_one(in, cam, antialiased, center, i, visible, clamped + 3 * i, sum, grads);
}

__global__ void background_grad_kernel(int64_t P, const float* d_comp, const float* final_t, float* d_bg) {
  const int64_t p = detail::global_index();
  if (p >= P) return;
  for (int c = 0; c < 3; ++c) d_bg[3 * p + c] = d_comp ? d_comp[3 * p + c] * final_t[p] : 0.0f;
}

__global__ void background_color_grad_kernel(int64_t P, const float* d_comp, const float* final_t, float* d_bg3) {
  const int64_t p = detail::global_index();
  float s[3] = {0.0f, 0.0f, 0.0f};
  if (p < P)
    for (int c = 0; c < 3; ++c) s[c] = d_comp[3 * p + c] * final_t[p];
  for (int c = 0; c < 3; ++c) detail::block_sum_atomic(s[c], d_bg3 + c);
}

__global__ void pixel_alpha_kernel(const Proj* g, const float* px, const float* py, int n, float* alpha, float* power,
                                   uint8_t* clamped) {
  const int64_t i = detail::global_index();
  if (i >= n) return;
  float dx, dy, gauss = 0.0f;
  bool cl = false;
  alpha[i] = gs::pixel_alpha(g[i], px[i], py[i], dx, dy, gauss, cl);
  power[i] = gs::pixel_power(g[i], dx, dy);
  clamped[i] = cl ? 1 : 0;
}

int bits_for(uint32_t n) {  // smallest b with 2^b >= n
  int b = 0;
  while (b < 32 && (uint64_t(1) << b) < n) ++b;
  return b;
}

}  // namespace

void rasterize_gaussians_cuda(const GaussianInputs<float>& in, const Camera& cam,
                              const GaussianRasterSettings<float>& settings, GaussianRasterCudaState& st,
                              const GaussianRasterOutputs<float>& out) {
  const char* where = "rasterize_gaussians_cuda";
  validate(in, cam, where);
  const int W = cam.width, H = cam.height, n = in.count;
  st.width = W;
  st.height = H;
  st.count = n;
  st.tiles_x = (W + kTileSize - 1) / kTileSize;
  st.tiles_y = (H + kTileSize - 1) / kTileSize;
  st.has_depth = settings.depth_map != nullptr;
  const int tiles = st.tiles_x * st.tiles_y;
  const int64_t P = int64_t(W) * H;

  st.radii.resize(size_t(n));
  st.proj.resize(size_t(n));
  st.color_clamped.assign_zero(size_t(3) * n);
  st.pair_count.resize(size_t(n));
  st.pair_offset.resize(size_t(n));
  st.tile_max_depth.resize(size_t(tiles));
  st.tile_range.assign_zero(size_t(2) * tiles);
  st.final_t.resize(size_t(P));
  st.last.resize(size_t(P));

  if (st.has_depth) {
    tile_max_depth_kernel<<<tiles, kTilePixels>>>(settings.depth_map, W, H, st.tiles_x, st.tile_max_depth.data());
    check_launch("tile_max_depth_kernel");
  }
  const Vec3f center = gs::camera_center(cam);
  HAHA_LAUNCH(project_kernel, n, detail::kThreads, 0, in, cam, settings.antialiased, center, st.tiles_x, st.has_depth,
              st.tile_max_depth.data(), st.proj.data(), st.radii.data(), st.color_clamped.data(),
              st.pair_count.data());

  // Pair offsets by Gaussian index (inclusive scan), and the total.
  st.num_pairs = 0;
  if (n > 0) {
    size_t scan_bytes = 0;
    HAHA_CUDA_CHECK(cub::DeviceScan::InclusiveSum(nullptr, scan_bytes, st.pair_count.data(), st.pair_offset.data(), n));
    st.temp.resize(scan_bytes);
    HAHA_CUDA_CHECK(
        cub::DeviceScan::InclusiveSum(st.temp.data(), scan_bytes, st.pair_count.data(), st.pair_offset.data(), n));
    uint32_t total = 0;
    HAHA_CUDA_CHECK(cudaMemcpy(&total, st.pair_offset.data() + (n - 1), sizeof total, cudaMemcpyDeviceToHost));
    // uint32 sums wrap; the CPU path's limit (int32) is far below what fits in memory anyway.
    if (total >= uint32_t(std::numeric_limits<int32_t>::max()))
      fail(where, "too many (Gaussian, tile) pairs: " + std::to_string(total));
    st.num_pairs = total;
  }
  const int64_t pairs = st.num_pairs;
  if (pairs > 0) {
    st.keys.resize(size_t(pairs));
    st.keys_sorted.resize(size_t(pairs));
    st.values.resize(size_t(pairs));
    st.tile_list.resize(size_t(pairs));
    HAHA_LAUNCH(emit_pairs_kernel, n, detail::kThreads, 0, n, st.proj.data(), st.radii.data(), st.pair_count.data(),
                st.pair_offset.data(), st.tiles_x, st.has_depth, st.tile_max_depth.data(), st.keys.data(),
                st.values.data());
    // Stable LSD radix sort on (tile, depth): pairs were emitted in Gaussian order, so equal
    // keys keep index order, as the CPU's (z, index) sort.
    const int end_bit = 32 + bits_for(uint32_t(tiles));
    size_t sort_bytes = 0;
    HAHA_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, sort_bytes, st.keys.data(), st.keys_sorted.data(),
                                                    st.values.data(), st.tile_list.data(), int(pairs), 0, end_bit));
    st.temp.resize(sort_bytes);
    HAHA_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(st.temp.data(), sort_bytes, st.keys.data(), st.keys_sorted.data(),
                                                    st.values.data(), st.tile_list.data(), int(pairs), 0, end_bit));
    HAHA_LAUNCH(tile_range_kernel, pairs, detail::kThreads, 0, pairs, st.keys_sorted.data(), st.tile_range.data());
  }

  RenderArgs a{W,
               H,
               st.tiles_x,
               st.tile_range.data(),
               st.tile_list.data(),
               st.proj.data(),
               settings.depth_map,
               settings.background,
               settings.background_color,
               out,
               st.final_t.data(),
               st.last.data()};
  render_kernel<<<tiles, kTilePixels>>>(a);
  check_launch("render_kernel");
}

void rasterize_gaussians_backward_cuda(const GaussianInputs<float>& in, const Camera& cam,
                                       const GaussianRasterSettings<float>& settings, GaussianRasterCudaState& st,
                                       const GaussianRasterOutputGrads<float>& dout,
                                       const GaussianGrads<float>& grads) {
  const char* where = "rasterize_gaussians_backward_cuda";
  validate(in, cam, where);
  const int W = cam.width, H = cam.height, n = in.count;
  if (st.width != W || st.height != H || st.count != n)
    fail(where, "state does not come from a forward with these inputs");
  const int tiles = st.tiles_x * st.tiles_y;
  const int64_t P = int64_t(W) * H;
  st.grad_sum.assign_zero(size_t(n) * kSlots);
  BackwardArgs a{W,
                 H,
                 st.tiles_x,
                 st.tile_range.data(),
                 st.tile_list.data(),
                 st.proj.data(),
                 st.final_t.data(),
                 st.last.data(),
                 settings,
                 dout,
                 grads.removal_cost != nullptr,
                 st.grad_sum.data()};
  render_backward_kernel<<<tiles, kTilePixels>>>(a);
  check_launch("render_backward_kernel");
  HAHA_LAUNCH(gaussian_backward_kernel, n, detail::kThreads, 0, in, cam, settings.antialiased,
              gs::camera_center(cam), st.radii.data(), st.color_clamped.data(), st.grad_sum.data(), grads);
  if (settings.background && grads.background)
    HAHA_LAUNCH(background_grad_kernel, P, detail::kThreads, 0, P, dout.composite, st.final_t.data(),
                grads.background);
  if (!settings.background && grads.background_color) {
    HAHA_CUDA_CHECK(cudaMemsetAsync(grads.background_color, 0, 3 * sizeof(float)));
    if (dout.composite)
      HAHA_LAUNCH(background_color_grad_kernel, P, detail::kThreads, 0, P, dout.composite, st.final_t.data(),
                  grads.background_color);
  }
}

std::vector<float> render_gaussians_image_cuda(const GaussianInputs<float>& h, const Camera& cam, Vec3f background,
                                               bool antialiased) {
  validate(h, cam, "render_gaussians_image_cuda");
  const size_t n = size_t(h.count);
  auto up = [&](const float* p, size_t count, DeviceBuffer<float>& b) -> const float* {
    if (!p) return nullptr;
    b.upload(p, count);
    return b.data();
  };
  DeviceBuffer<float> means, quats, scales, opac, colors, sh, image;
  GaussianInputs<float> d = h;
  d.means = up(h.means, 3 * n, means);
  d.quats = up(h.quats, 4 * n, quats);
  d.scales = up(h.scales, 3 * n, scales);
  d.opacities = up(h.opacities, n, opac);
  d.colors = up(h.colors, 3 * n, colors);
  d.sh = up(h.sh, 3 * n * size_t(sh_coeff_count(h.sh_degree)), sh);
  GaussianRasterSettings<float> s;
  s.antialiased = antialiased;
  s.background_color = background;
  image.resize(size_t(cam.width) * cam.height * 3);
  GaussianRasterOutputs<float> out;
  out.composite = image.data();
  GaussianRasterCudaState state;
  rasterize_gaussians_cuda(d, cam, s, state, out);
  return image.to_host();
}

void pixel_alpha_cuda(const gs::ProjectedGaussian<float>* g, const float* px, const float* py, int n, float* alpha,
                      float* power, uint8_t* clamped) {
  HAHA_LAUNCH(pixel_alpha_kernel, n, detail::kThreads, 0, g, px, py, n, alpha, power, clamped);
}

}  // namespace haha::cuda
