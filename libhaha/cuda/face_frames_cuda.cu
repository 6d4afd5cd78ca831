#include "cuda/face_frames_cuda.h"

#include <string>

#include "cuda/device_util.cuh"

namespace haha::cuda {

namespace {

using detail::AtomicAdd;

__device__ __forceinline__ Vec3<float> corner(const float* verts, const int32_t* faces, int f, int i) {
  return Vec3<float>::load(verts + 3 * int64_t(faces[3 * f + i]));
}

__global__ void face_frames_kernel(const float* verts, const int32_t* faces, int F, float divisor,
                                   FaceFrame<float>* frames) {
  const int f = int(detail::global_index());
  if (f >= F) return;
  frames[f] = face_frame(corner(verts, faces, f, 0), corner(verts, faces, f, 1), corner(verts, faces, f, 2), divisor);
}

__global__ void face_frames_backward_kernel(const float* verts, const int32_t* faces, int F, float divisor,
                                            const FaceFrameGrad<float>* d_frames, float* d_verts) {
  const int f = int(detail::global_index());
  if (f >= F) return;
  Vec3<float> dc[3];
  face_frame_backward(corner(verts, faces, f, 0), corner(verts, faces, f, 1), corner(verts, faces, f, 2), divisor,
                      d_frames[f], dc[0], dc[1], dc[2]);
  for (int i = 0; i < 3; ++i) {
    float* d = d_verts + 3 * int64_t(faces[3 * f + i]);
    atomicAdd(d, dc[i].x);
    atomicAdd(d + 1, dc[i].y);
    atomicAdd(d + 2, dc[i].z);
  }
}

__global__ void pose_gaussians_kernel(const FaceFrame<float>* frames, GaussianLocalView<float> g, float* means,
                                      float* quats, float* scales) {
  const int64_t i = detail::global_index();
  if (i >= g.n) return;
  Vec3<float> mu_w, s_w;
  Quat<float> r_w;
  pose_gaussian(frames[g.face[i]], Vec3<float>::load(g.offset + 3 * i), Quat<float>::load(g.rotation + 4 * i),
                Vec3<float>::load(g.scale + 3 * i), mu_w, r_w, s_w);
  mu_w.store(means + 3 * i);
  r_w.store(quats + 4 * i);
  s_w.store(scales + 3 * i);
}

__device__ __forceinline__ void atomic_add_frame_grad(FaceFrameGrad<float>* dst, const FaceFrameGrad<float>& g) {
  for (int k = 0; k < 3; ++k) atomicAdd(&dst->t[k], g.t[k]);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) atomicAdd(&dst->R.a[r][c], g.R.a[r][c]);
  atomicAdd(&dst->q.w, g.q.w);
  atomicAdd(&dst->q.x, g.q.x);
  atomicAdd(&dst->q.y, g.q.y);
  atomicAdd(&dst->q.z, g.q.z);
  atomicAdd(&dst->k, g.k);
}

__global__ void pose_gaussians_backward_kernel(const FaceFrame<float>* frames, GaussianLocalView<float> g,
                                               const float* d_means, const float* d_quats, const float* d_scales,
                                               float* d_offset, float* d_rotation, float* d_scale,
                                               FaceFrameGrad<float>* d_frames) {
  const int64_t i = detail::global_index();
  if (i >= g.n) return;
  const Vec3<float> zero3{};
  const Quat<float> zero4{0, 0, 0, 0};
  FaceFrameGrad<float> df;
  Vec3<float> dmu{}, ds{};
  Quat<float> dr{0, 0, 0, 0};
  const int f = g.face[i];
  pose_gaussian_backward(frames[f], Vec3<float>::load(g.offset + 3 * i), Quat<float>::load(g.rotation + 4 * i),
                         Vec3<float>::load(g.scale + 3 * i), d_means ? Vec3<float>::load(d_means + 3 * i) : zero3,
                         d_quats ? Quat<float>::load(d_quats + 4 * i) : zero4,
                         d_scales ? Vec3<float>::load(d_scales + 3 * i) : zero3, dmu, dr, ds, df);
  if (d_offset)
    for (int c = 0; c < 3; ++c) d_offset[3 * i + c] += dmu[c];
  if (d_scale)
    for (int c = 0; c < 3; ++c) d_scale[3 * i + c] += ds[c];
  if (d_rotation) {
    d_rotation[4 * i] += dr.w;
    d_rotation[4 * i + 1] += dr.x;
    d_rotation[4 * i + 2] += dr.y;
    d_rotation[4 * i + 3] += dr.z;
  }
  if (d_frames) atomic_add_frame_grad(d_frames + f, df);
}

__global__ void check_indices_kernel(const int32_t* idx, int64_t n, int limit, unsigned long long* first_bad) {
  const int64_t i = detail::global_index();
  if (i >= n) return;
  if (idx[i] < 0 || idx[i] >= limit) atomicMin(first_bad, (unsigned long long)i);
}

}  // namespace

void face_frames_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                      FaceFrame<float>* frames) {
  HAHA_LAUNCH(face_frames_kernel, num_faces, detail::kThreads, 0, verts, faces, num_faces, divisor, frames);
}

void face_frames_backward_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                               const FaceFrameGrad<float>* d_frames, float* d_verts) {
  HAHA_LAUNCH(face_frames_backward_kernel, num_faces, detail::kThreads, 0, verts, faces, num_faces, divisor, d_frames,
              d_verts);
}

void pose_gaussians_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                         const GaussianLocalView<float>& g, float* means, float* quats, float* scales,
                         PoseGaussiansScratch& scratch) {
  scratch.frames.resize(size_t(num_faces));
  face_frames_cuda(verts, faces, num_faces, divisor, scratch.frames.data());
  HAHA_LAUNCH(pose_gaussians_kernel, g.n, detail::kThreads, 0, scratch.frames.data(), g, means, quats, scales);
}

void pose_gaussians_backward_cuda(const float* verts, const int32_t* faces, int num_faces, float divisor,
                                  const GaussianLocalView<float>& g, const float* d_means, const float* d_quats,
                                  const float* d_scales, float* d_verts, float* d_offset, float* d_rotation,
                                  float* d_scale, PoseGaussiansScratch& scratch) {
  scratch.frames.resize(size_t(num_faces));
  face_frames_cuda(verts, faces, num_faces, divisor, scratch.frames.data());
  FaceFrameGrad<float>* dframes = nullptr;
  if (d_verts) {
    scratch.d_frames.assign_zero(size_t(num_faces));
    dframes = scratch.d_frames.data();
  }
  HAHA_LAUNCH(pose_gaussians_backward_kernel, g.n, detail::kThreads, 0, scratch.frames.data(), g, d_means, d_quats,
              d_scales, d_offset, d_rotation, d_scale, dframes);
  if (d_verts) face_frames_backward_cuda(verts, faces, num_faces, divisor, dframes, d_verts);
}

void check_indices_cuda(const int32_t* idx, int64_t n, int limit, const char* where) {
  if (n <= 0) return;
  DeviceBuffer<unsigned long long> bad(1);
  const unsigned long long none = ~0ull;
  HAHA_CUDA_CHECK(cudaMemcpy(bad.data(), &none, sizeof none, cudaMemcpyHostToDevice));
  HAHA_LAUNCH(check_indices_kernel, n, detail::kThreads, 0, idx, n, limit, bad.data());
  unsigned long long first = none;
  bad.download(&first, 1);
  if (first != none) {
    int32_t v = 0;
    HAHA_CUDA_CHECK(cudaMemcpy(&v, idx + first, sizeof v, cudaMemcpyDeviceToHost));
    fail(where, "index " + std::to_string(first) + " is " + std::to_string(v) + ", outside [0, " +
                    std::to_string(limit) + ")");
  }
}

}  // namespace haha::cuda
