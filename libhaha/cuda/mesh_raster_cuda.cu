#include "cuda/mesh_raster_cuda.h"

#include <cmath>
#include <string>

#include "cuda/device_util.cuh"

namespace haha::cuda {

namespace {

using detail::AtomicAdd;
constexpr unsigned long long kEmpty = ~0ull;

void check_camera(const Camera& cam, const char* fn) {
  if (cam.width <= 0 || cam.height <= 0)
    fail(fn, "camera size " + std::to_string(cam.width) + "x" + std::to_string(cam.height) + " is not positive");
  if (!(cam.fx > 0 && cam.fy > 0 && std::isfinite(cam.fx) && std::isfinite(cam.fy) && std::isfinite(cam.cx) &&
        std::isfinite(cam.cy)))
    fail(fn, "camera intrinsics must be finite with positive focal lengths");
  if (!(cam.near_plane > 0 && cam.far_plane > cam.near_plane && std::isfinite(cam.far_plane)))
    fail(fn, "camera needs 0 < near < far < inf");
}

__global__ void to_camera_kernel(Camera cam, const float* verts, int V, float* cv) {
  const int64_t i = detail::global_index();
  if (i >= V) return;
  cam.to_camera(Vec3f::load(verts + 3 * i)).store(cv + 3 * i);
}

__global__ void setup_kernel(Camera cam, const float* cv, const int32_t* faces, const float* coverage, int F,
                             TriSetup* setups) {
  const int64_t f = detail::global_index();
  if (f >= F) return;
  const int32_t* idx = faces + 3 * f;
  const Vec3f v[3] = {Vec3f::load(cv + 3 * idx[0]), Vec3f::load(cv + 3 * idx[1]), Vec3f::load(cv + 3 * idx[2])};
  TriSetup s;
  setup_triangle(cam, v, &s);
  setup_coverage_cut(coverage, idx, &s);
  setups[f] = s;
}

// One warp per face: lanes stride over the face's pixel box.
__global__ void raster_kernel(Camera cam, const TriSetup* setups, int F, unsigned long long* zbuf) {
  const int64_t f = detail::global_index() >> 5;
  const int lane = int(threadIdx.x) & 31;
  if (f >= F) return;
  const TriSetup s = setups[f];
  if (s.x0 > s.x1) return;
  const int bw = s.x1 - s.x0 + 1;
  const int64_t n = int64_t(bw) * (s.y1 - s.y0 + 1);
  for (int64_t k = lane; k < n; k += 32) {
    const int x = s.x0 + int(k % bw), y = s.y0 + int(k / bw);
    float z;
    if (tri_covers(s, pixel_ray(cam, x, y), cam.near_plane, cam.far_plane, &z))
      atomicMin(zbuf + int64_t(y) * cam.width + x, (static_cast<unsigned long long>(__float_as_uint(z)) << 32) |
                                                       static_cast<unsigned long long>(f));
  }
}

__global__ void resolve_kernel(Camera cam, const TriSetup* setups, const unsigned long long* zbuf, int32_t* tri,
                               float* bary, float* depth, float* mask) {
  const int64_t p = detail::global_index();
  if (p >= int64_t(cam.width) * cam.height) return;
  const unsigned long long key = zbuf[p];
  float* b = bary + 3 * p;
  if (key == kEmpty) {
    tri[p] = -1;
    b[0] = b[1] = b[2] = 0.0f;
    depth[p] = INFINITY;
    mask[p] = 0.0f;
    return;
  }
  const int f = int(key & 0xffffffffull);
  const TriSetup& s = setups[f];
  TriEdges<float> e;
  e.n[0] = s.n[0];
  e.n[1] = s.n[1];
  e.n[2] = s.n[2];
  e.N = s.N;
  e.det = s.det;
  float z;
  tri_bary_depth(e, pixel_ray(cam, int(p % cam.width), int(p / cam.width)), b, &z);
  tri[p] = f;
  depth[p] = z;
  mask[p] = 1.0f;
}

__global__ void bary_backward_kernel(Camera cam, MeshView mesh, const int32_t* tri, const float* grad_bary,
                                     const float* grad_depth, float* grad_verts) {
  const int64_t p = detail::global_index();
  if (p >= int64_t(cam.width) * cam.height) return;
  const int f = tri[p];
  if (f < 0) return;
  const float gb[3] = {grad_bary[3 * p], grad_bary[3 * p + 1], grad_bary[3 * p + 2]};
  int idx[3];
  Vec3f gw[3];
  barycentrics_backward_pixel(cam, mesh, f, int(p % cam.width), int(p / cam.width), gb,
                              grad_depth ? grad_depth[p] : 0.0f, idx, gw);
  for (int i = 0; i < 3; ++i) {
    float* dst = grad_verts + 3 * int64_t(idx[i]);
    atomicAdd(dst, gw[i].x);
    atomicAdd(dst + 1, gw[i].y);
    atomicAdd(dst + 2, gw[i].z);
  }
}

__global__ void interpolate_kernel(int P, const int32_t* tri, const float* bary, const int32_t* attr_index,
                                   const float* attr, int C, float* out) {
  const int64_t p = detail::global_index();
  if (p >= P) return;
  float* o = out + p * C;
  const int f = tri[p];
  if (f < 0) {
    for (int c = 0; c < C; ++c) o[c] = 0.0f;
    return;
  }
  interpolate_pixel(p, f, bary, attr_index, attr, C, o);
}

__global__ void interpolate_backward_kernel(int P, const int32_t* tri, const float* bary, const int32_t* attr_index,
                                            const float* attr, int C, const float* grad_out, float* grad_attr,
                                            float* grad_bary) {
  const int64_t p = detail::global_index();
  if (p >= P) return;
  const int f = tri[p];
  if (grad_bary) {
    float* gb = grad_bary + 3 * p;
    if (f < 0)
      gb[0] = gb[1] = gb[2] = 0.0f;
    else
      interpolate_backward_bary_pixel(f, attr_index, attr, C, grad_out + p * C, gb);
  }
  if (grad_attr && f >= 0) interpolate_backward_attr_pixel(p, f, bary, attr_index, C, grad_out + p * C, grad_attr,
                                                          AtomicAdd{});
}

__global__ void sample_kernel(TextureView tex, int P, const int32_t* tri, const float* uv, float* out) {
  const int64_t p = detail::global_index();
  if (p >= P) return;
  float* o = out + p * tex.channels;
  if (tri && tri[p] < 0) {
    for (int c = 0; c < tex.channels; ++c) o[c] = 0.0f;
    return;
  }
  bilinear_sample(tex, uv[2 * p], uv[2 * p + 1], o);
}

__global__ void sample_backward_kernel(TextureView tex, int P, const int32_t* tri, const float* uv,
                                       const float* grad_out, float* grad_texture, float* grad_uv) {
  const int64_t p = detail::global_index();
  if (p >= P) return;
  float gu = 0.0f, gv = 0.0f;
  if (!tri || tri[p] >= 0)
    bilinear_sample_backward(tex, uv[2 * p], uv[2 * p + 1], grad_out + p * tex.channels, grad_texture, &gu, &gv,
                             AtomicAdd{});
  if (grad_uv) {
    grad_uv[2 * p] = gu;
    grad_uv[2 * p + 1] = gv;
  }
}

void check_texture(const TextureView& tex, int num_pixels, const float* uv, const char* fn) {
  if (tex.width <= 0 || tex.height <= 0 || tex.channels <= 0 || !tex.data)
    fail(fn, "texture is empty (" + std::to_string(tex.width) + "x" + std::to_string(tex.height) + "x" +
                 std::to_string(tex.channels) + ")");
  if (num_pixels < 0 || (num_pixels > 0 && !uv)) fail(fn, "null uv buffer");
}

}  // namespace

void rasterize_mesh_cuda(const Camera& cam, const MeshView& mesh, MeshRasterCuda& out) {
  const char* fn = "rasterize_mesh_cuda";
  check_camera(cam, fn);
  if (mesh.num_verts < 0 || mesh.num_faces < 0) fail(fn, "negative vertex or face count");
  if ((mesh.num_verts > 0 && !mesh.verts) || (mesh.num_faces > 0 && !mesh.faces)) fail(fn, "null vertex or face buffer");
  const int W = cam.width, H = cam.height;
  const int64_t P = int64_t(W) * H;
  out.width = W;
  out.height = H;
  out.tri.resize(size_t(P));
  out.bary.resize(size_t(P) * 3);
  out.depth.resize(size_t(P));
  out.mask.resize(size_t(P));
  out.zbuf.resize(size_t(P));
  HAHA_CUDA_CHECK(cudaMemsetAsync(out.zbuf.data(), 0xff, size_t(P) * sizeof(unsigned long long)));
  out.cam_verts.resize(size_t(mesh.num_verts) * 3);
  out.setup.resize(size_t(mesh.num_faces));
  HAHA_LAUNCH(to_camera_kernel, mesh.num_verts, detail::kThreads, 0, cam, mesh.verts, mesh.num_verts,
              out.cam_verts.data());
  HAHA_LAUNCH(setup_kernel, mesh.num_faces, detail::kThreads, 0, cam, out.cam_verts.data(), mesh.faces,
              mesh.coverage, mesh.num_faces, out.setup.data());
  HAHA_LAUNCH(raster_kernel, int64_t(mesh.num_faces) * 32, detail::kThreads, 0, cam, out.setup.data(),
              mesh.num_faces, out.zbuf.data());
  HAHA_LAUNCH(resolve_kernel, P, detail::kThreads, 0, cam, out.setup.data(), out.zbuf.data(), out.tri.data(),
              out.bary.data(), out.depth.data(), out.mask.data());
}

void mesh_barycentrics_backward_cuda(const Camera& cam, const MeshView& mesh, const int32_t* tri,
                                     const float* grad_bary, const float* grad_depth, float* grad_verts) {
  HAHA_LAUNCH(bary_backward_kernel, int64_t(cam.width) * cam.height, detail::kThreads, 0, cam, mesh, tri, grad_bary,
              grad_depth, grad_verts);
}

void interpolate_cuda(int num_pixels, const int32_t* tri, const float* bary, const int32_t* attr_index,
                      const float* attr, int channels, float* out) {
  HAHA_LAUNCH(interpolate_kernel, num_pixels, detail::kThreads, 0, num_pixels, tri, bary, attr_index, attr, channels,
              out);
}

void interpolate_backward_cuda(int num_pixels, const int32_t* tri, const float* bary, const int32_t* attr_index,
                               const float* attr, int channels, const float* grad_out, float* grad_attr,
                               float* grad_bary) {
  HAHA_LAUNCH(interpolate_backward_kernel, num_pixels, detail::kThreads, 0, num_pixels, tri, bary, attr_index, attr,
              channels, grad_out, grad_attr, grad_bary);
}

void sample_texture_cuda(const TextureView& tex, int num_pixels, const int32_t* tri, const float* uv, float* out) {
  check_texture(tex, num_pixels, uv, "sample_texture_cuda");
  HAHA_LAUNCH(sample_kernel, num_pixels, detail::kThreads, 0, tex, num_pixels, tri, uv, out);
}

void sample_texture_backward_cuda(const TextureView& tex, int num_pixels, const int32_t* tri, const float* uv,
                                  const float* grad_out, float* grad_texture, float* grad_uv) {
  check_texture(tex, num_pixels, uv, "sample_texture_backward_cuda");
  HAHA_LAUNCH(sample_backward_kernel, num_pixels, detail::kThreads, 0, tex, num_pixels, tri, uv, grad_out,
              grad_texture, grad_uv);
}

void render_mesh_cuda(const Camera& cam, const MeshRenderInput& in, MeshRenderCuda& out) {
  const char* fn = "render_mesh_cuda";
  if (in.num_faces > 0 && (!in.uv_faces || !in.uv)) fail(fn, "null UV buffer");
  rasterize_mesh_cuda(cam, MeshView{in.verts, in.num_verts, in.faces, in.num_faces, in.coverage}, out.raster);
  const int P = out.raster.num_pixels();
  const int C = in.texture.channels;
  out.uv.resize(size_t(P) * 2);
  out.color.resize(size_t(P) * C);
  interpolate_cuda(P, out.raster.tri.data(), out.raster.bary.data(), in.uv_faces, in.uv, 2, out.uv.data());
  sample_texture_cuda(in.texture, P, out.raster.tri.data(), out.uv.data(), out.color.data());
}

void render_mesh_backward_cuda(const Camera& cam, const MeshRenderInput& in, MeshRenderCuda& fwd,
                               const float* grad_color, const float* grad_depth, float* grad_texture,
                               float* grad_verts) {
  const int P = fwd.raster.num_pixels();
  if (P != cam.width * cam.height) fail("render_mesh_backward_cuda", "forward buffers do not match the camera size");
  const int32_t* tri = fwd.raster.tri.data();
  if (!grad_verts) {
    if (grad_texture && grad_color)
      sample_texture_backward_cuda(in.texture, P, tri, fwd.uv.data(), grad_color, grad_texture, nullptr);
    return;
  }
  fwd.grad_bary.resize(size_t(P) * 3);
  if (grad_color) {
    fwd.grad_uv.resize(size_t(P) * 2);
    sample_texture_backward_cuda(in.texture, P, tri, fwd.uv.data(), grad_color, grad_texture, fwd.grad_uv.data());
    interpolate_backward_cuda(P, tri, fwd.raster.bary.data(), in.uv_faces, in.uv, 2, fwd.grad_uv.data(), nullptr,
                              fwd.grad_bary.data());
  } else {
    fwd.grad_bary.zero();  // depth-only gradient
  }
  mesh_barycentrics_backward_cuda(cam, MeshView{in.verts, in.num_verts, in.faces, in.num_faces}, tri,
                                  fwd.grad_bary.data(), grad_depth, grad_verts);
}

}  // namespace haha::cuda
