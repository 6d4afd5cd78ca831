// HAHA_HD marks functions that compile for both host and CUDA device code.
// Every kernel body in libhaha is written once with this macro; CPU launchers
// (parallel_for) and CUDA launchers (*.cu) call the same inline function.
#pragma once

#if defined(__CUDACC__)
#define HAHA_HD __host__ __device__ __forceinline__
#define HAHA_DEVICE_CODE 1
#else
#define HAHA_HD inline
#define HAHA_DEVICE_CODE 0
#endif

namespace haha {
// Accumulation policy of kernels that scatter-add into shared buffers: the CPU launchers
// own their destination (per-thread buffers) and add plainly; CUDA launchers pass an
// atomic policy (cuda/device_util.cuh). Same maths, same operation order per item.
struct PlainAdd {
  template <class T>
  HAHA_HD void operator()(T* dst, T v) const { *dst += v; }
};
}  // namespace haha
