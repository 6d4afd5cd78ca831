// Parallel loops (libhaha/core/parallel.h): every index runs exactly once whatever the size
// (none, one, below and above the serial threshold, odd counts), per-index results written
// by index add up in order to the serial sum, and the thread count set is the one used.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <vector>

#include "core/parallel.h"

namespace haha {
namespace {

// Sizes around the serial threshold and odd counts that do not split evenly over threads.
const int64_t kSizes[] = {0, 1, 2, 3, 7, kMinParallelItems - 1, kMinParallelItems, kMinParallelItems + 1, 10007};

template <class Loop>
void expect_each_index_once(Loop loop) {
  for (int64_t n : kSizes) {
    std::vector<std::atomic<int>> hits(static_cast<size_t>(n));
    for (auto& h : hits) h = 0;
    loop(n, [&](int64_t i) {
      ASSERT_GE(i, 0);
      ASSERT_LT(i, n);
      hits[static_cast<size_t>(i)]++;
    });
    for (int64_t i = 0; i < n; ++i) ASSERT_EQ(hits[static_cast<size_t>(i)].load(), 1) << "n " << n << " i " << i;
  }
}

TEST(Parallel, StaticLoopRunsEveryIndexOnce) {
  expect_each_index_once([](int64_t n, auto&& f) { parallel_for(n, f); });
}

TEST(Parallel, DynamicLoopRunsEveryIndexOnce) {
  expect_each_index_once([](int64_t n, auto&& f) { parallel_for_dynamic(n, f); });
}

TEST(Parallel, PerIndexResultsSumInOrderToTheSerialSum) {
  // Floats whose sum depends on the order: a parallel reduction would differ in the last
  // bits; writing per index and summing in index order must equal the serial loop exactly.
  const int64_t n = 3 * kMinParallelItems + 5;
  auto term = [](int64_t i) { return float(1.0 / double(i + 1)) * ((i % 3 == 0) ? 1e4f : 1e-3f); };
  float serial = 0;
  for (int64_t i = 0; i < n; ++i) serial += term(i);
  std::vector<float> a(static_cast<size_t>(n)), b(static_cast<size_t>(n));
  parallel_for(n, [&](int64_t i) { a[static_cast<size_t>(i)] = term(i); });
  parallel_for_dynamic(n, [&](int64_t i) { b[static_cast<size_t>(i)] = term(i); });
  float sa = 0, sb = 0;
  for (int64_t i = 0; i < n; ++i) sa += a[static_cast<size_t>(i)], sb += b[static_cast<size_t>(i)];
  EXPECT_EQ(sa, serial);
  EXPECT_EQ(sb, serial);
}

TEST(Parallel, ThreadCountIsTheOneSetAndZeroKeepsIt) {
  const int before = num_threads();
  set_num_threads(3);
#ifdef _OPENMP
  EXPECT_EQ(num_threads(), 3);
  std::vector<std::atomic<int>> used(3);
  for (auto& u : used) u = 0;
  parallel_for_dynamic(64, [&](int64_t) {
    const int t = thread_index();
    ASSERT_GE(t, 0);
    ASSERT_LT(t, 3);
    used[static_cast<size_t>(t)]++;
  });
  int total = 0;
  for (auto& u : used) total += u.load();
  EXPECT_EQ(total, 64);
  set_num_threads(0);  // `--threads 0`: keep the current count
  EXPECT_EQ(num_threads(), 3);
  set_num_threads(-2);
  EXPECT_EQ(num_threads(), 3);
#else
  EXPECT_EQ(num_threads(), 1);
  EXPECT_EQ(thread_index(), 0);
#endif
  set_num_threads(before);
  EXPECT_EQ(num_threads(), before);
  // Outside a parallel region the caller is thread 0.
  EXPECT_EQ(thread_index(), 0);
}

}  // namespace
}  // namespace haha
