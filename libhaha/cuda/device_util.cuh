// Internal helpers of the .cu launchers (not part of the public API): launch shapes, the
// atomic accumulation policy for the shared HAHA_HD kernels, and block reductions.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/cuda_base.h"

namespace haha::cuda::detail {

constexpr int kThreads = 256;

inline unsigned blocks_for(int64_t n, int threads = kThreads) {
  return unsigned((n + threads - 1) / threads);
}

// Launch guard: a grid of zero blocks is an error in CUDA; empty work is not.
#define HAHA_LAUNCH(kernel, n, threads, smem, ...)                                    \
  do {                                                                                \
    const int64_t haha_n_ = (n);                                                      \
    if (haha_n_ > 0) {                                                                \
      kernel<<<::haha::cuda::detail::blocks_for(haha_n_, (threads)), (threads), (smem)>>>(__VA_ARGS__); \
      ::haha::cuda::check_launch(#kernel);                                            \
    }                                                                                 \
  } while (0)

// The accumulation policy of core/hd.h's PlainAdd, made atomic on the device.
struct AtomicAdd {
  template <class T>
  __host__ __device__ __forceinline__ void operator()(T* dst, T v) const {
#if defined(__CUDA_ARCH__)
    atomicAdd(dst, v);
#else
    *dst += v;
#endif
  }
};

// Grid-stride index range.
__device__ __forceinline__ int64_t global_index() { return int64_t(blockIdx.x) * blockDim.x + threadIdx.x; }

template <class T>
__device__ __forceinline__ T warp_sum(T v) {
  for (int off = 16; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
  return v;
}

// Sum of v over the block, added atomically into *dst by one thread. Every thread of the
// block must call it (it synchronises). Block size: a multiple of 32, at most 1024.
template <class T>
__device__ __forceinline__ void block_sum_atomic(T v, T* dst) {
  __shared__ T part[32];
  v = warp_sum(v);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  __syncthreads();  // part[] may still be read by a previous call
  if (lane == 0) part[warp] = v;
  __syncthreads();
  if (warp == 0) {
    const int nw = (blockDim.x + 31) >> 5;
    T s = lane < nw ? part[lane] : T(0);
    s = warp_sum(s);
    if (lane == 0) atomicAdd(dst, s);
  }
}

}  // namespace haha::cuda::detail
