// CPU launcher: runs body(i) for i in [0, n) over OpenMP threads. Kernel bodies are
// HAHA_HD functions of an index, so a CUDA launcher (one thread per index) can call the
// same body. set_num_threads() is how `--threads N` reaches every parallel loop.
#pragma once

#include <cstdint>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace haha {

inline void set_num_threads(int n) {
#ifdef _OPENMP
  if (n > 0) omp_set_num_threads(n);
#else
  (void)n;
#endif
}

inline int num_threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

inline int thread_index() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

// Below this many cheap iterations a parallel region costs more than it saves.
constexpr int64_t kMinParallelItems = 2048;

// Static schedule: equal-cost iterations (vertices, Gaussians). Small loops run serially.
template <class F>
void parallel_for(int64_t n, F&& body) {
#pragma omp parallel for schedule(static) if (n >= kMinParallelItems)
  for (int64_t i = 0; i < n; ++i) body(i);
}

// Dynamic schedule: uneven iterations (image tiles, whose lists differ in length).
template <class F>
void parallel_for_dynamic(int64_t n, F&& body) {
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t i = 0; i < n; ++i) body(i);
}

}  // namespace haha
