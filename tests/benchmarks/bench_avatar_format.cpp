// Speed of the avatar file path on the CPU for a realistic-size avatar (full procedural
// body, 12k Gaussians, 512^2 texture): pack (default, lossless), load (parse + Draco +
// image decode + validation), repose (LBS + face frames) and render (mesh + Gaussians +
// merge) at 512 x 512.
//   cmake --build build --target bench_avatar_format && build/tests/bench_avatar_format
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "support/format_realistic_avatar.h"

using namespace haha;

namespace {

const Avatar& avatar() {
  static const Avatar a = test::make_realistic_avatar(12000, 512);
  return a;
}

const std::vector<uint8_t>& packed() {
  static const std::vector<uint8_t> b = pack_avatar(avatar(), PackOptions{});
  return b;
}

SmplxParams pose() {
  SmplxParams p;
  p.pose[3 * 16 + 2] = -1.0f;
  p.pose[3 * 17 + 2] = 1.0f;
  p.pose[3 * 4] = 0.5f;
  return p;
}

Camera camera(int size) {
  Camera c;
  c.width = c.height = size;
  c.fx = c.fy = 1.3f * size;
  c.cx = c.cy = 0.5f * size;
  c.R.a[1][1] = -1;
  c.R.a[2][2] = -1;
  c.t = {0, -0.1f, 2.8f};
  return c;
}

void BM_Pack(benchmark::State& state) {
  PackOptions o;
  o.lossless = state.range(0) != 0;
  size_t bytes = 0;
  for (auto _ : state) bytes = pack_avatar(avatar(), o).size();
  state.counters["bytes"] = double(bytes);
}
BENCHMARK(BM_Pack)->Arg(0)->Arg(1)->ArgNames({"lossless"})->Unit(benchmark::kMillisecond);

void BM_Load(benchmark::State& state) {
  for (auto _ : state) {
    UnpackedAvatar u = unpack_avatar(packed().data(), packed().size(), "bench.glb");
    benchmark::DoNotOptimize(u.avatar.gaussians.face.data());
  }
}
BENCHMARK(BM_Load)->Unit(benchmark::kMillisecond);

void BM_Repose(benchmark::State& state) {
  const AvatarLoader rt(unpack_avatar(packed().data(), packed().size(), "bench.glb").avatar);
  PosedAvatar posed;
  const SmplxParams p = pose();
  for (auto _ : state) rt.repose(p, posed);
}
BENCHMARK(BM_Repose)->Unit(benchmark::kMillisecond);

void BM_Render(benchmark::State& state) {
  const AvatarLoader rt(unpack_avatar(packed().data(), packed().size(), "bench.glb").avatar);
  PosedAvatar posed;
  rt.repose(pose(), posed);
  AvatarRenderScratch scratch;
  std::vector<float> rgb;
  const Camera cam = camera(int(state.range(0)));
  for (auto _ : state) rt.render(cam, posed, rgb, {}, scratch);
  state.counters["FPS"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Render)->Arg(512)->ArgNames({"size"})->Unit(benchmark::kMillisecond);

}  // namespace
