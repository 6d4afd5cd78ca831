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

// HAHA_SIMD before a loop whose iterations are independent (elementwise, no reduction):
// the project builds at -O2, where GCC vectorises such a loop only when told. Elementwise
// float arithmetic gives the same bits vectorised or not (no FMA contraction on the x86-64
// baseline). Empty in CUDA sources and without OpenMP.
#if defined(__CUDACC__) || !defined(_OPENMP)
#define HAHA_SIMD
#else
#define HAHA_SIMD _Pragma("omp simd")
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
