// Speed of the training losses at the paper's sizes (544 x 544 renders, batch element by
// element), the KNN search / regulariser at SMPL-X Gaussian counts, and LPIPS with
// full-size random weights (AlexNet at 512 x 512 for the metric, VGG16 at 256 x 256 for
// the loss). Build: cmake --build BUILD --target bench_train_losses.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "train/knn.h"
#include "train/losses.h"
#include "train/lpips.h"

using namespace haha;

namespace {
std::vector<float> random_floats(size_t n, unsigned seed, float lo = 0.f, float hi = 1.f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = u(rng);
  return v;
}

constexpr int kSize = 544;

void BM_L2(benchmark::State& s) {
  auto x = random_floats(kSize * kSize * 3, 1), y = random_floats(kSize * kSize * 3, 2);
  std::vector<float> g(x.size());
  for (auto _ : s) benchmark::DoNotOptimize(l2_loss<float>(x.data(), y.data(), kSize, kSize, nullptr, g.data()));
}
BENCHMARK(BM_L2)->Unit(benchmark::kMillisecond);

void BM_Ssim(benchmark::State& s) {
  auto x = random_floats(kSize * kSize * 3, 1), y = random_floats(kSize * kSize * 3, 2);
  std::vector<float> g(x.size());
  LossScratch<float> scratch;
  const bool with_grad = s.range(0) != 0;
  for (auto _ : s)
    benchmark::DoNotOptimize(
        ssim_loss<float>(x.data(), y.data(), kSize, kSize, scratch, nullptr, with_grad ? g.data() : nullptr));
}
BENCHMARK(BM_Ssim)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_Edge(benchmark::State& s) {
  auto x = random_floats(kSize * kSize * 3, 1), y = random_floats(kSize * kSize * 3, 2);
  std::vector<float> g(x.size());
  LossScratch<float> scratch;
  for (auto _ : s)
    benchmark::DoNotOptimize(edge_loss<float>(x.data(), y.data(), kSize, kSize, scratch, nullptr, g.data()));
}
BENCHMARK(BM_Edge)->Unit(benchmark::kMillisecond);

void BM_TextureTv(benchmark::State& s) {
  // Stage 2's regulariser on the texture sizes of the presets (tiny 256, paper 512, standard 1024).
  const int n = int(s.range(0));
  auto t = random_floats(size_t(n) * n * 3, 3);
  std::vector<float> g(t.size());
  for (auto _ : s) benchmark::DoNotOptimize(texture_tv_loss<float>(t.data(), n, n, 3, g.data()));
}
BENCHMARK(BM_TextureTv)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_KnnSearch(benchmark::State& s) {
  // Points on an ellipsoid shell, the shape of Gaussians bound to a body surface.
  const int64_t n = s.range(0);
  std::mt19937 rng(3);
  std::normal_distribution<float> g(0.f, 1.f);
  std::vector<float> p(size_t(3 * n));
  for (int64_t i = 0; i < n; ++i) {
    float v[3] = {g(rng), g(rng), g(rng)};
    const float r = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    p[size_t(3 * i)] = 0.3f * v[0] / r;
    p[size_t(3 * i + 1)] = 0.9f * v[1] / r;
    p[size_t(3 * i + 2)] = 0.15f * v[2] / r;
  }
  std::vector<int32_t> sets(size_t(3 * n));
  for (auto _ : s) knn_sets(p.data(), n, 3, sets.data());
}
BENCHMARK(BM_KnnSearch)->Arg(20908)->Arg(100000)->Unit(benchmark::kMillisecond);

void BM_KnnReg(benchmark::State& s) {
  const int64_t n = s.range(0);
  auto pos = random_floats(size_t(3 * n), 4, -1, 1), rot = random_floats(size_t(4 * n), 5),
       sc = random_floats(size_t(3 * n), 6), op = random_floats(size_t(n), 7), col = random_floats(size_t(3 * n), 8);
  std::vector<int32_t> sets(size_t(3 * n));
  knn_sets(pos.data(), n, 3, sets.data());
  std::vector<float> gp(pos.size()), gr(rot.size()), gs(sc.size()), go(op.size()), gc(col.size());
  KnnRegInputs<float> in{n, pos.data(), rot.data(), sc.data(), op.data(), col.data()};
  KnnRegGrads<float> gr_{gp.data(), gr.data(), gs.data(), go.data(), gc.data()};
  for (auto _ : s) benchmark::DoNotOptimize(knn_reg<float>(in, sets.data(), 3, {}, &gr_));
}
BENCHMARK(BM_KnnReg)->Arg(20908)->Arg(100000)->Unit(benchmark::kMillisecond);

LpipsWeights full_size_weights(LpipsBackbone b) {
  struct C {
    int idx, out, k;
  };
  std::vector<C> convs;
  std::vector<int> taps;
  if (b == LpipsBackbone::Alex) {
    convs = {{0, 64, 11}, {3, 192, 5}, {6, 384, 3}, {8, 256, 3}, {10, 256, 3}};
    taps = {0, 3, 6, 8, 10};
  } else {
    convs = {{0, 64, 3},   {2, 64, 3},   {5, 128, 3},  {7, 128, 3},  {10, 256, 3}, {12, 256, 3}, {14, 256, 3},
             {17, 512, 3}, {19, 512, 3}, {21, 512, 3}, {24, 512, 3}, {26, 512, 3}, {28, 512, 3}};
    taps = {2, 7, 14, 21, 28};
  }
  LpipsWeights w;
  w.source = "random";
  const std::string p = lpips_prefix(b);
  int in = 3, t = 0;
  unsigned seed = 10;
  for (const C& c : convs) {
    const float s = std::sqrt(2.f / float(in * c.k * c.k));
    w.tensors[p + ".features." + std::to_string(c.idx) + ".weight"] =
        LpipsTensor{{c.out, in, c.k, c.k}, random_floats(size_t(c.out) * in * c.k * c.k, seed++, -s, s)};
    w.tensors[p + ".features." + std::to_string(c.idx) + ".bias"] =
        LpipsTensor{{c.out}, random_floats(size_t(c.out), seed++, -0.01f, 0.01f)};
    in = c.out;
    if (c.idx == taps[size_t(t)])
      w.tensors[p + ".lin." + std::to_string(t++) + ".weight"] =
          LpipsTensor{{1, c.out, 1, 1}, random_floats(size_t(c.out), seed++, 0.f, 0.1f)};
  }
  return w;
}

void BM_LpipsAlexMetric512(benchmark::State& s) {
  LpipsNet<float> net(full_size_weights(LpipsBackbone::Alex), LpipsBackbone::Alex);
  auto x = random_floats(512 * 512 * 3, 1), y = random_floats(512 * 512 * 3, 2);
  for (auto _ : s) benchmark::DoNotOptimize(net.distance(x.data(), y.data(), 512, 512));
}
BENCHMARK(BM_LpipsAlexMetric512)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_LpipsVggLoss256(benchmark::State& s) {
  LpipsNet<float> net(full_size_weights(LpipsBackbone::Vgg16), LpipsBackbone::Vgg16);
  auto x = random_floats(256 * 256 * 3, 1), y = random_floats(256 * 256 * 3, 2);
  std::vector<float> g(x.size());
  for (auto _ : s) benchmark::DoNotOptimize(net.distance(x.data(), y.data(), 256, 256, g.data()));
}
BENCHMARK(BM_LpipsVggLoss256)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
