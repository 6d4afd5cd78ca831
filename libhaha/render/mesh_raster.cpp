#include "render/mesh_raster.h"

#include <algorithm>
#include <string>

#include "core/error.h"
#include "core/parallel.h"
#include "render/scatter.h"

namespace haha {

namespace {

void check_camera(const Camera& cam, const char* fn) {
  const std::string where = fn;
  if (cam.width <= 0 || cam.height <= 0)
    fail(where, "camera size " + std::to_string(cam.width) + "x" + std::to_string(cam.height) + " is not positive");
  if (!(cam.fx > 0 && cam.fy > 0 && std::isfinite(cam.fx) && std::isfinite(cam.fy) && std::isfinite(cam.cx) &&
        std::isfinite(cam.cy)))
    fail(where, "camera intrinsics must be finite with positive focal lengths");
  if (!(cam.near_plane > 0 && cam.far_plane > cam.near_plane && std::isfinite(cam.far_plane)))
    fail(where, "camera needs 0 < near < far < inf");
}

void check_mesh(const MeshView& mesh, const char* fn) {
  const std::string where = fn;
  if (mesh.num_verts < 0 || mesh.num_faces < 0) fail(where, "negative vertex or face count");
  if ((mesh.num_verts > 0 && !mesh.verts) || (mesh.num_faces > 0 && !mesh.faces))
    fail(where, "null vertex or face buffer");
  for (int64_t i = 0; i < int64_t(mesh.num_faces) * 3; ++i) {
    const int32_t v = mesh.faces[i];
    if (v < 0 || v >= mesh.num_verts)
      fail(where, "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(v) + " outside [0, " +
                      std::to_string(mesh.num_verts) + ")");
  }
}

}  // namespace

void rasterize_mesh(const Camera& cam, const MeshView& mesh, MeshRaster& out) {
  check_camera(cam, "rasterize_mesh");
  check_mesh(mesh, "rasterize_mesh");
  const int W = cam.width, H = cam.height;
  const int64_t P = int64_t(W) * H;
  out.width = W;
  out.height = H;
  out.tri.resize(P);
  out.bary.resize(P * 3);
  out.depth.resize(P);
  out.mask.resize(P);

  const int V = mesh.num_verts, F = mesh.num_faces;
  out.scratch_cam_verts.resize(size_t(V) * 3);
  float* cv = out.scratch_cam_verts.data();
  detail::parallel_items(V, [&](int64_t i) { cam.to_camera(Vec3f::load(mesh.verts + 3 * i)).store(cv + 3 * i); });

  out.scratch_setup.resize(F);
  TriSetup* setups = out.scratch_setup.data();
  detail::parallel_items(F, [&](int64_t f) {
    const int32_t* idx = mesh.faces + 3 * f;
    const Vec3f v[3] = {Vec3f::load(cv + 3 * idx[0]), Vec3f::load(cv + 3 * idx[1]), Vec3f::load(cv + 3 * idx[2])};
    setup_triangle(cam, v, &setups[f]);
    setup_coverage_cut(mesh.coverage, idx, &setups[f]);
  });

  // Bin triangles into tiles in ascending triangle order (ties in depth then go to the
  // lower index because each tile tests its list in order with a strict depth compare).
  const int tw = (W + kRasterTile - 1) / kRasterTile, th = (H + kRasterTile - 1) / kRasterTile;
  const int ntiles = tw * th;
  std::vector<int32_t>& start = out.scratch_bin_start;
  start.assign(size_t(ntiles) + 1, 0);
  for (int f = 0; f < F; ++f) {
    const TriSetup& s = setups[f];
    if (s.x0 > s.x1) continue;
    for (int ty = s.y0 / kRasterTile; ty <= s.y1 / kRasterTile; ++ty)
      for (int tx = s.x0 / kRasterTile; tx <= s.x1 / kRasterTile; ++tx) ++start[ty * tw + tx + 1];
  }
  for (int t = 0; t < ntiles; ++t) start[t + 1] += start[t];
  std::vector<int32_t>& items = out.scratch_bin_items;
  items.resize(start[ntiles]);
  std::vector<int32_t>& fill = out.scratch_tri_tiles;
  fill.assign(start.begin(), start.end() - 1);
  for (int f = 0; f < F; ++f) {
    const TriSetup& s = setups[f];
    if (s.x0 > s.x1) continue;
    for (int ty = s.y0 / kRasterTile; ty <= s.y1 / kRasterTile; ++ty)
      for (int tx = s.x0 / kRasterTile; tx <= s.x1 / kRasterTile; ++tx) items[fill[ty * tw + tx]++] = f;
  }

  const float nr = cam.near_plane, fr = cam.far_plane;
  auto tile = [&](int64_t t) {
    const int tx0 = int(t % tw) * kRasterTile, ty0 = int(t / tw) * kRasterTile;
    const int tx1 = std::min(tx0 + kRasterTile, W) - 1, ty1 = std::min(ty0 + kRasterTile, H) - 1;
    if (start[t] == start[t + 1]) {  // empty tile: background only
      for (int y = ty0; y <= ty1; ++y) {
        const int64_t p0 = int64_t(y) * W + tx0, n = tx1 - tx0 + 1;
        std::fill_n(out.tri.data() + p0, n, -1);
        std::fill_n(out.bary.data() + 3 * p0, 3 * n, 0.0f);
        std::fill_n(out.depth.data() + p0, n, INFINITY);
        std::fill_n(out.mask.data() + p0, n, 0.0f);
      }
      return;
    }
    float zbuf[kRasterTile * kRasterTile];
    int32_t ibuf[kRasterTile * kRasterTile];
    float dx[kRasterTile], dy[kRasterTile];
    for (int i = 0; i < kRasterTile * kRasterTile; ++i) {
      zbuf[i] = INFINITY;
      ibuf[i] = -1;
    }
    for (int x = tx0; x <= tx1; ++x) dx[x - tx0] = pixel_ray(cam, x, 0).x;
    for (int y = ty0; y <= ty1; ++y) dy[y - ty0] = pixel_ray(cam, 0, y).y;

    for (int32_t k = start[t]; k < start[t + 1]; ++k) {
      const int f = items[k];
      const TriSetup& s = setups[f];
      const int x0 = std::max(s.x0, tx0), x1 = std::min(s.x1, tx1);
      const int y0 = std::max(s.y0, ty0), y1 = std::min(s.y1, ty1);
      for (int y = y0; y <= y1; ++y) {
        const int row = (y - ty0) * kRasterTile - tx0;
        for (int x = x0; x <= x1; ++x) {
          float z;
          if (tri_covers(s, Vec3f(dx[x - tx0], dy[y - ty0], 1.0f), nr, fr, &z) && z < zbuf[row + x]) {
            zbuf[row + x] = z;
            ibuf[row + x] = f;
          }
        }
      }
    }

    // Resolve: barycentrics with the same kernel as mesh_barycentrics (the set-up normals
    // are the exact (sign-flipped) edge normals, so the ratios are identical).
    for (int y = ty0; y <= ty1; ++y)
      for (int x = tx0; x <= tx1; ++x) {
        const int l = (y - ty0) * kRasterTile + (x - tx0);
        const int64_t p = int64_t(y) * W + x;
        const int f = ibuf[l];
        out.tri[p] = f;
        float* b = out.bary.data() + 3 * p;
        if (f < 0) {
          b[0] = b[1] = b[2] = 0.0f;
          out.depth[p] = INFINITY;
          out.mask[p] = 0.0f;
          continue;
        }
        const TriSetup& s = setups[f];
        TriEdges<float> e;
        e.n[0] = s.n[0];
        e.n[1] = s.n[1];
        e.n[2] = s.n[2];
        e.N = s.N;
        e.det = s.det;
        float z;
        tri_bary_depth(e, Vec3f(dx[x - tx0], dy[y - ty0], 1.0f), b, &z);
        out.depth[p] = z;
        out.mask[p] = 1.0f;
      }
  };
  if (P < detail::kSerialBelow) {
    for (int t = 0; t < ntiles; ++t) tile(t);
  } else {
    parallel_for_dynamic(ntiles, tile);
  }
}

// ---------------------------------------------------------------------------------------

template <class T>
void mesh_barycentrics(const CameraT<T>& cam, const MeshViewT<T>& mesh, const int32_t* tri, NoDeduce<T>* bary,
                       NoDeduce<T>* depth) {
  const int W = cam.width;
  const int64_t P = int64_t(W) * cam.height;
  detail::parallel_items(P, [&](int64_t p) {
    const int f = tri[p];
    if (f < 0) {
      if (bary) bary[3 * p] = bary[3 * p + 1] = bary[3 * p + 2] = T(0);
      if (depth) depth[p] = std::numeric_limits<T>::infinity();
      return;
    }
    T b[3], z;
    barycentrics_pixel(cam, mesh, f, int(p % W), int(p / W), b, &z);
    if (bary) bary[3 * p] = b[0], bary[3 * p + 1] = b[1], bary[3 * p + 2] = b[2];
    if (depth) depth[p] = z;
  });
}

template <class T>
void mesh_barycentrics_backward(const CameraT<T>& cam, const MeshViewT<T>& mesh, const int32_t* tri,
                                const NoDeduce<T>* grad_bary, const NoDeduce<T>* grad_depth, NoDeduce<T>* grad_verts) {
  const int W = cam.width;
  detail::scatter_add(int64_t(W) * cam.height, int64_t(mesh.num_verts) * 3, grad_verts, [&](int64_t p, T* g) {
    const int f = tri[p];
    if (f < 0) return;
    const T gb[3] = {grad_bary[3 * p], grad_bary[3 * p + 1], grad_bary[3 * p + 2]};
    int idx[3];
    Vec3<T> gw[3];
    barycentrics_backward_pixel(cam, mesh, f, int(p % W), int(p / W), gb, grad_depth ? grad_depth[p] : T(0), idx, gw);
    for (int i = 0; i < 3; ++i) {
      T* dst = g + 3 * int64_t(idx[i]);
      dst[0] += gw[i].x;
      dst[1] += gw[i].y;
      dst[2] += gw[i].z;
    }
  });
}

template <class T>
void interpolate(int num_pixels, const int32_t* tri, const T* bary, const int32_t* attr_index, const T* attr,
                 int channels, T* out) {
  const int C = channels;
  detail::parallel_items(num_pixels, [&](int64_t p) {
    T* o = out + p * C;
    const int f = tri[p];
    if (f < 0) {
      for (int c = 0; c < C; ++c) o[c] = T(0);
      return;
    }
    interpolate_pixel(p, f, bary, attr_index, attr, C, o);
  });
}

template <class T>
void interpolate_backward(int num_pixels, int num_attr, const int32_t* tri, const T* bary, const int32_t* attr_index,
                          const T* attr, int channels, const NoDeduce<T>* grad_out, NoDeduce<T>* grad_attr,
                          NoDeduce<T>* grad_bary) {
  const int C = channels;
  if (grad_bary) {
    detail::parallel_items(num_pixels, [&](int64_t p) {
      T* gb = grad_bary + 3 * p;
      const int f = tri[p];
      if (f < 0) {
        gb[0] = gb[1] = gb[2] = T(0);
        return;
      }
      interpolate_backward_bary_pixel(f, attr_index, attr, C, grad_out + p * C, gb);
    });
  }
  if (grad_attr) {
    detail::scatter_add(num_pixels, int64_t(num_attr) * C, grad_attr, [&](int64_t p, T* ga) {
      const int f = tri[p];
      if (f < 0) return;
      interpolate_backward_attr_pixel(p, f, bary, attr_index, C, grad_out + p * C, ga);
    });
  }
}

#define HAHA_INSTANTIATE(T)                                                                                        \
  template void mesh_barycentrics<T>(const CameraT<T>&, const MeshViewT<T>&, const int32_t*, T*, T*);            \
  template void mesh_barycentrics_backward<T>(const CameraT<T>&, const MeshViewT<T>&, const int32_t*, const T*,  \
                                              const T*, T*);                                                     \
  template void interpolate<T>(int, const int32_t*, const T*, const int32_t*, const T*, int, T*);                 \
  template void interpolate_backward<T>(int, int, const int32_t*, const T*, const int32_t*, const T*, int,        \
                                        const T*, T*, T*);
HAHA_INSTANTIATE(float)
HAHA_INSTANTIATE(double)
#undef HAHA_INSTANTIATE

}  // namespace haha
