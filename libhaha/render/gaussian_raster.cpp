// CPU launcher of the Gaussian rasterizer. Layout of the work:
//   1. project every Gaussian (parallel over Gaussians)
//   2. bin: sort visible Gaussians once by (z, index), then scatter them into per-tile
//      lists in that order (a counting sort by tile), so every list comes out depth-sorted;
//      a (Gaussian, tile) pair is dropped when the Gaussian is behind the whole tile's
//      occluder depth (it could not contribute to any pixel there)
//   3. per tile (parallel, dynamic): loop the tile's Gaussians in depth order and, for each,
//      the pixels of its footprint inside the tile, with per-pixel state on the stack
//   Backward replays step 3 back to front and accumulates per-(Gaussian, tile) gradients
//   into pair slots, then sums each Gaussian's pairs in a fixed order (deterministic, no
//   atomics) and chains them through the projection.
// The per-pixel steps and the per-Gaussian backward are HAHA_HD functions in
// render/gaussian_composite.h, shared with the CUDA launcher.
#include "render/gaussian_raster.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>

#include "core/error.h"
#include "core/parallel.h"
#include "render/gaussian_composite.h"
#include "render/sh.h"

namespace haha {
namespace {

using gs::kTileSize;
constexpr int kTilePixels = kTileSize * kTileSize;
constexpr int kPairGradSize = gs::kGradSlots;  // mx, my, ca, cb, cc, opacity, z, r, g, b, removal cost

template <class T>
void validate(const GaussianInputs<T>& in, const CameraT<T>& cam) {
  const char* where = "rasterize_gaussians";
  if (cam.width <= 0 || cam.height <= 0) fail(where, "camera has no pixels");
  if (!(cam.fx > 0) || !(cam.fy > 0)) fail(where, "camera focal lengths must be positive");
  if (in.count < 0) fail(where, "negative Gaussian count");
  if (in.count == 0) return;
  if (!in.means || !in.quats || !in.scales || !in.opacities) fail(where, "missing Gaussian buffer");
  if ((in.colors == nullptr) == (in.sh == nullptr)) fail(where, "exactly one of colors / sh must be given");
  if (in.sh && (in.sh_degree < 0 || in.sh_degree > kMaxShDegree)) fail(where, "sh_degree must be 0..3");
}

// Visible Gaussians sorted by (z, index). Float: stable LSD radix sort on the bits of z
// (positive floats order like their bit patterns). Double: comparison sort.
template <class T>
void sort_by_depth(GaussianRasterState<T>& st) {
  auto& order = st.order;
  order.clear();
  for (int i = 0; i < st.count; ++i)
    if (st.radii[size_t(i)] > 0) order.push_back(uint32_t(i));
  if constexpr (std::is_same_v<T, float>) {
    const size_t n = order.size();
    auto& tmp = st.scratch_u32;
    tmp.resize(3 * n);
    uint32_t* keys = tmp.data();
    uint32_t* keys2 = keys + n;
    uint32_t* idx2 = keys2 + n;
    uint32_t* idx = order.data();
    for (size_t k = 0; k < n; ++k) std::memcpy(&keys[k], &st.proj[idx[k]].z, 4);
    for (int shift = 0; shift < 32; shift += 8) {
      size_t hist[257] = {};
      for (size_t k = 0; k < n; ++k) ++hist[((keys[k] >> shift) & 255u) + 1];
      for (int b = 0; b < 256; ++b) hist[b + 1] += hist[b];
      for (size_t k = 0; k < n; ++k) {
        const size_t dst = hist[(keys[k] >> shift) & 255u]++;
        keys2[dst] = keys[k];
        idx2[dst] = idx[k];
      }
      std::swap(keys, keys2);
      std::swap(idx, idx2);
    }
    // Four passes: the result is back in the original buffers.
  } else {
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      const T za = st.proj[a].z, zb = st.proj[b].z;
      return za < zb || (za == zb && a < b);
    });
  }
}

template <class T>
void bin_gaussians(GaussianRasterState<T>& st, bool has_depth) {
  const int n = st.count;
  const int tiles = st.tiles_x * st.tiles_y;
  const T* tmax = st.tile_max_depth.data();
  // Per-Gaussian pair counts (parallel), then offsets by Gaussian index.
  st.pair_offsets.assign(size_t(n) + 1, 0);
  uint32_t* counts = st.pair_offsets.data() + 1;
  parallel_for(n, [&](int64_t i) {
    if (st.radii[size_t(i)] <= 0) return;
    const auto& p = st.proj[size_t(i)];
    const auto r = gs::tile_rect(p);
    uint32_t c = 0;
    for (int ty = r.y0; ty <= r.y1; ++ty)
      for (int tx = r.x0; tx <= r.x1; ++tx) c += gs::pair_visible(p, has_depth, tmax[ty * st.tiles_x + tx]);
    counts[i] = c;
    if (c == 0) st.radii[size_t(i)] = 0;  // behind the occluder everywhere it reaches
  });
  uint64_t total = 0;
  for (int i = 0; i < n; ++i) {
    total += counts[i];
    counts[i] = uint32_t(total);
    if (total >= uint64_t(std::numeric_limits<int32_t>::max()))
      fail("rasterize_gaussians", "too many (Gaussian, tile) pairs: " + std::to_string(total));
  }
  sort_by_depth(st);
  // Tile counts, then a scatter in depth order so each tile list is depth-sorted.
  st.tile_offsets.assign(size_t(tiles) + 1, 0);
  uint32_t* tcount = st.tile_offsets.data() + 1;
  for (uint32_t g : st.order) {
    const auto& p = st.proj[g];
    const auto r = gs::tile_rect(p);
    for (int ty = r.y0; ty <= r.y1; ++ty)
      for (int tx = r.x0; tx <= r.x1; ++tx) {
        const int t = ty * st.tiles_x + tx;
        tcount[t] += gs::pair_visible(p, has_depth, tmax[t]);
      }
  }
  for (int t = 0; t < tiles; ++t) tcount[t] += st.tile_offsets[size_t(t)];
  st.tile_list.resize(total);
  st.pair_slots.resize(total);
  auto& cursor = st.scratch_u32;
  cursor.assign(st.tile_offsets.begin(), st.tile_offsets.end() - 1);
  for (uint32_t g : st.order) {
    const auto& p = st.proj[g];
    const auto r = gs::tile_rect(p);
    uint32_t slot = st.pair_offsets[g];
    for (int ty = r.y0; ty <= r.y1; ++ty)
      for (int tx = r.x0; tx <= r.x1; ++tx) {
        const int t = ty * st.tiles_x + tx;
        if (!gs::pair_visible(p, has_depth, tmax[t])) continue;
        const uint32_t pos = cursor[size_t(t)]++;
        st.tile_list[pos] = g;
        st.pair_slots[slot++] = pos;
      }
  }
}

template <class T>
T background_at(const GaussianRasterSettings<T>& s, int64_t pix, int c) {
  return s.background ? s.background[3 * pix + c] : s.background_color[c];
}

}  // namespace

template <class T>
void rasterize_gaussians(const GaussianInputs<T>& in, const CameraT<T>& cam, const GaussianRasterSettings<T>& settings,
                         GaussianRasterState<T>& st, const GaussianRasterOutputs<T>& out) {
  validate(in, cam);
  const int W = cam.width, H = cam.height, n = in.count;
  st.width = W;
  st.height = H;
  st.count = n;
  st.tiles_x = (W + kTileSize - 1) / kTileSize;
  st.tiles_y = (H + kTileSize - 1) / kTileSize;
  const int tiles = st.tiles_x * st.tiles_y;
  st.radii.assign(size_t(n), 0);
  st.proj.resize(size_t(n));
  st.color_clamped.assign(size_t(3) * n, 0);
  const Vec3<T> center = gs::camera_center(cam);

  parallel_for(n, [&](int64_t i) {
    gs::ProjectionCache<T> cache;
    auto& p = st.proj[size_t(i)];
    if (!gs::project_gaussian(cam, in.means + 3 * i, in.quats + 4 * i, in.scales + 3 * i, in.opacities[i],
                              settings.antialiased, p, cache))
      return;
    const Vec3<T> c = gs::gaussian_color(in, center, i, &st.color_clamped[size_t(3 * i)]);
    p.color[0] = c.x;
    p.color[1] = c.y;
    p.color[2] = c.z;
    st.radii[size_t(i)] = int32_t(std::ceil(std::min(cache.radius, T(1e9))));  // >= 1
  });

  const bool has_depth = settings.depth_map != nullptr;
  st.tile_max_depth.assign(size_t(tiles), std::numeric_limits<T>::infinity());
  if (has_depth) {
    parallel_for(tiles, [&](int64_t t) {
      const int tx = int(t % st.tiles_x), ty = int(t / st.tiles_x);
      T m = -std::numeric_limits<T>::infinity();
      for (int y = ty * kTileSize; y < std::min(H, (ty + 1) * kTileSize); ++y)
        for (int x = tx * kTileSize; x < std::min(W, (tx + 1) * kTileSize); ++x) {
          const T d = settings.depth_map[int64_t(y) * W + x];
          m = gs::tile_depth_fold(m, d);
        }
      st.tile_max_depth[size_t(t)] = m;
    });
  }
  bin_gaussians(st, has_depth);

  st.final_t.resize(size_t(W) * H);
  st.last.resize(size_t(W) * H);
  parallel_for_dynamic(tiles, [&](int64_t t) {
    const int tx = int(t % st.tiles_x), ty = int(t / st.tiles_x);
    const int px0 = tx * kTileSize, py0 = ty * kTileSize;
    const int pw = std::min(kTileSize, W - px0), ph = std::min(kTileSize, H - py0);
    T trans[kTilePixels], col[3 * kTilePixels], dep[kTilePixels], dmap[kTilePixels];
    int32_t last[kTilePixels];
    uint8_t done[kTilePixels];
    for (int l = 0; l < kTilePixels; ++l) {
      trans[l] = 1;
      col[3 * l] = col[3 * l + 1] = col[3 * l + 2] = 0;
      dep[l] = 0;
      last[l] = -1;
      done[l] = 0;
      dmap[l] = std::numeric_limits<T>::infinity();
    }
    if (has_depth)
      for (int y = 0; y < ph; ++y)
        for (int x = 0; x < pw; ++x) dmap[y * kTileSize + x] = settings.depth_map[int64_t(py0 + y) * W + px0 + x];
    const int npix = pw * ph;
    int ndone = 0;
    const uint32_t begin = st.tile_offsets[size_t(t)], end = st.tile_offsets[size_t(t) + 1];
    for (uint32_t pos = begin; pos < end && ndone < npix; ++pos) {
      const auto& g = st.proj[st.tile_list[pos]];
      const int x0 = std::max(g.x0, px0) - px0, x1 = std::min(g.x1, px0 + pw - 1) - px0;
      const int y0 = std::max(g.y0, py0) - py0, y1 = std::min(g.y1, py0 + ph - 1) - py0;
      for (int y = y0; y <= y1; ++y) {
        const T py = T(py0 + y) + T(0.5);
        for (int x = x0; x <= x1; ++x) {
          const int l = y * kTileSize + x;
          if (done[l]) continue;
          if (gs::composite_step(g, T(px0 + x) + T(0.5), py, dmap[l], int32_t(pos), trans[l], col + 3 * l, dep[l],
                                 last[l])) {
            done[l] = 1;
            ++ndone;
          }
        }
      }
    }
    for (int y = 0; y < ph; ++y)
      for (int x = 0; x < pw; ++x) {
        const int l = y * kTileSize + x;
        const int64_t pix = int64_t(py0 + y) * W + px0 + x;
        st.final_t[size_t(pix)] = trans[l];
        st.last[size_t(pix)] = last[l];
        if (out.color)
          for (int c = 0; c < 3; ++c) out.color[3 * pix + c] = col[3 * l + c];
        if (out.alpha) out.alpha[pix] = 1 - trans[l];
        if (out.depth) out.depth[pix] = dep[l];
        if (out.composite)
          for (int c = 0; c < 3; ++c) out.composite[3 * pix + c] = col[3 * l + c] + trans[l] * background_at(settings, pix, c);
      }
  });
}

template <class T>
void rasterize_gaussians_backward(const GaussianInputs<T>& in, const CameraT<T>& cam,
                                  const GaussianRasterSettings<T>& settings, GaussianRasterState<T>& st,
                                  const GaussianRasterOutputGrads<T>& dout, const GaussianGrads<T>& grads) {
  validate(in, cam);
  const int W = cam.width, H = cam.height, n = in.count;
  if (st.width != W || st.height != H || st.count != n)
    fail("rasterize_gaussians_backward", "state does not come from a forward with these inputs");
  const int tiles = st.tiles_x * st.tiles_y;
  st.pair_grad.resize(size_t(st.pairs()) * kPairGradSize);

  parallel_for_dynamic(tiles, [&](int64_t t) {
    const int tx = int(t % st.tiles_x), ty = int(t / st.tiles_x);
    const int px0 = tx * kTileSize, py0 = ty * kTileSize;
    const int pw = std::min(kTileSize, W - px0), ph = std::min(kTileSize, H - py0);
    const uint32_t begin = st.tile_offsets[size_t(t)], end = st.tile_offsets[size_t(t) + 1];
    T* pg = st.pair_grad.data();
    // Per pixel: transmittance walked back from T_final, colour/depth of the Gaussians
    // behind (already visited), upstream gradients.
    T trans[kTilePixels], behind[3 * kTilePixels], behind_z[kTilePixels];
    T d_col[3 * kTilePixels], d_dep[kTilePixels], d_tf[kTilePixels], tfin[kTilePixels];
    T backdrop_t[3 * kTilePixels];  // removal cost only
    const bool cost = grads.removal_cost != nullptr;
    int32_t last[kTilePixels];
    int64_t max_last = int64_t(begin) - 1;
    for (int l = 0; l < kTilePixels; ++l) last[l] = -1;
    for (int y = 0; y < ph; ++y)
      for (int x = 0; x < pw; ++x) {
        const int l = y * kTileSize + x;
        const int64_t pix = int64_t(py0 + y) * W + px0 + x;
        last[l] = st.last[size_t(pix)];
        max_last = std::max<int64_t>(max_last, last[l]);
        trans[l] = tfin[l] = st.final_t[size_t(pix)];
        behind[3 * l] = behind[3 * l + 1] = behind[3 * l + 2] = behind_z[l] = 0;
        gs::pixel_upstream(settings, dout, pix, d_col + 3 * l, d_dep[l], d_tf[l]);
        if (cost) gs::pixel_backdrop(settings, dout, pix, tfin[l], backdrop_t + 3 * l);
      }
    for (int64_t pos = max_last + 1; pos < int64_t(end); ++pos)
      std::fill(pg + pos * kPairGradSize, pg + (pos + 1) * kPairGradSize, T(0));
    for (int64_t pos = max_last; pos >= int64_t(begin); --pos) {
      const auto& g = st.proj[st.tile_list[size_t(pos)]];
      gs::ProjectedGrad<T> acc;
      T acc_col[3] = {0, 0, 0}, acc_cost = 0;
      const int x0 = std::max(g.x0, px0) - px0, x1 = std::min(g.x1, px0 + pw - 1) - px0;
      const int y0 = std::max(g.y0, py0) - py0, y1 = std::min(g.y1, py0 + ph - 1) - py0;
      for (int y = y0; y <= y1; ++y) {
        const T py = T(py0 + y) + T(0.5);
        for (int x = x0; x <= x1; ++x) {
          const int l = y * kTileSize + x;
          if (pos > last[l]) continue;
          gs::composite_step_backward(g, T(px0 + x) + T(0.5), py, trans[l], tfin[l], behind + 3 * l, behind_z[l],
                                      d_col + 3 * l, d_dep[l], d_tf[l], acc, acc_col,
                                      cost ? backdrop_t + 3 * l : nullptr, &acc_cost);
        }
      }
      T* dst = pg + pos * kPairGradSize;
      dst[0] = acc.mx;
      dst[1] = acc.my;
      dst[2] = acc.ca;
      dst[3] = acc.cb;
      dst[4] = acc.cc;
      dst[5] = acc.opacity;
      dst[6] = acc.z;
      dst[7] = acc_col[0];
      dst[8] = acc_col[1];
      dst[9] = acc_col[2];
      dst[10] = acc_cost;
    }
  });

  const Vec3<T> center = gs::camera_center(cam);
  parallel_for(n, [&](int64_t i) {
    const bool visible = st.radii[size_t(i)] > 0;
    T sum[kPairGradSize] = {};
    if (visible)
      for (uint32_t k = st.pair_offsets[size_t(i)]; k < st.pair_offsets[size_t(i) + 1]; ++k) {
        const T* src = st.pair_grad.data() + size_t(st.pair_slots[k]) * kPairGradSize;
        for (int j = 0; j < kPairGradSize; ++j) sum[j] += src[j];
      }
    gs::gaussian_backward_one(in, cam, settings.antialiased, center, i, visible, &st.color_clamped[size_t(3 * i)], sum,
                              grads);
  });

  // Background: composite = ... + T_final * bg.
  if (settings.background && grads.background) {
    parallel_for(int64_t(W) * H, [&](int64_t pix) {
      for (int c = 0; c < 3; ++c)
        grads.background[3 * pix + c] = dout.composite ? dout.composite[3 * pix + c] * st.final_t[size_t(pix)] : T(0);
    });
  }
  if (!settings.background && grads.background_color) {
    T s[3] = {0, 0, 0};
    if (dout.composite)
      for (int64_t pix = 0; pix < int64_t(W) * H; ++pix)
        for (int c = 0; c < 3; ++c) s[c] += dout.composite[3 * pix + c] * st.final_t[size_t(pix)];
    for (int c = 0; c < 3; ++c) grads.background_color[c] = s[c];
  }
}

template void rasterize_gaussians<float>(const GaussianInputs<float>&, const CameraT<float>&,
                                         const GaussianRasterSettings<float>&, GaussianRasterState<float>&,
                                         const GaussianRasterOutputs<float>&);
template void rasterize_gaussians<double>(const GaussianInputs<double>&, const CameraT<double>&,
                                          const GaussianRasterSettings<double>&, GaussianRasterState<double>&,
                                          const GaussianRasterOutputs<double>&);
template void rasterize_gaussians_backward<float>(const GaussianInputs<float>&, const CameraT<float>&,
                                                  const GaussianRasterSettings<float>&, GaussianRasterState<float>&,
                                                  const GaussianRasterOutputGrads<float>&,
                                                  const GaussianGrads<float>&);
template void rasterize_gaussians_backward<double>(const GaussianInputs<double>&, const CameraT<double>&,
                                                   const GaussianRasterSettings<double>&, GaussianRasterState<double>&,
                                                   const GaussianRasterOutputGrads<double>&,
                                                   const GaussianGrads<double>&);

}  // namespace haha
