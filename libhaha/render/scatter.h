// Internal helpers of the render launchers. scatter_add: per-item work (pixels) that scatter-adds into a
// shared buffer (per-vertex or per-texel gradients). Each thread gets its own zeroed copy
// and the copies are summed in a fixed order, so results are deterministic for a given
// thread count and no atomics are needed on the CPU (a CUDA launcher uses atomicAdd).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/parallel.h"

namespace haha::detail {

// parallel_for with a grain: small launches (finite-difference tests, tiny images) run on
// the calling thread, where waking a thread team would cost more than the work.
constexpr int64_t kSerialBelow = 4096;
template <class F>
void parallel_items(int64_t n, F&& body) {
  if (n < kSerialBelow) {
    for (int64_t i = 0; i < n; ++i) body(i);
  } else {
    parallel_for(n, body);
  }
}

// Calls item(i, buf) for every i in [0, n); buf is a (size)-element buffer that ends up
// ACCUMULATED into dst. Blocks of items are interleaved between threads for balance (an
// image's busy rows are usually in its middle).
template <class T, class F>
void scatter_add(int64_t n, int64_t size, T* dst, F&& item) {
  constexpr int64_t kBlock = 1024;
  const int64_t blocks = (n + kBlock - 1) / kBlock;
  const int chunks = n < kSerialBelow ? 1 : int(std::max<int64_t>(1, std::min<int64_t>(num_threads(), blocks)));
  if (chunks == 1) {
    for (int64_t i = 0; i < n; ++i) item(i, dst);
    return;
  }
  std::vector<T> bufs(size_t(chunks) * size_t(size), T(0));
  parallel_for(chunks, [&](int64_t c) {
    T* buf = bufs.data() + c * size;
    for (int64_t b = c; b < blocks; b += chunks)
      for (int64_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) item(i, buf);
  });
  parallel_items(size, [&](int64_t i) {
    T s = dst[i];
    for (int c = 0; c < chunks; ++c) s += bufs[size_t(c) * size_t(size) + size_t(i)];
    dst[i] = s;
  });
}

}  // namespace haha::detail
