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
