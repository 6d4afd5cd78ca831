// `haha synth` speed: building the clothed subject (geometry + 512 px texture) and
// rendering one ground-truth frame (LBS, garments, 3 x 3 supersampled raster, texture
// lookups, box filter) at 128 and 512 px, on the full procedural body.
//   cmake --build build --target bench_synth && OMP_NUM_THREADS=2 build/tests/bench_synth
#include <benchmark/benchmark.h>

#include "body/procedural_body.h"
#include "synth/synth_subject.h"

using namespace haha;

namespace {

const BodyModel& body() {
  static const BodyModel b = make_procedural_body({});
  return b;
}
const SynthSubject& subject() {
  static const SynthSubject s = make_synth_subject(body(), {});
  return s;
}

void BM_SynthSubject(benchmark::State& state) {
  SynthSubjectOptions o;
  o.texture_size = int(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(make_synth_subject(body(), o));
}
BENCHMARK(BM_SynthSubject)->Arg(512)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_SynthRenderFrame(benchmark::State& state) {
  const int size = int(state.range(0));
  const SynthMotion m = make_synth_motion(body(), subject(), 8, 2, 0);
  SynthRenderer r(body(), subject());
  std::vector<const SmplxParams*> frames = {&m.train[0], &m.test[0]};
  const Camera cam = synth_camera(r, frames, size);
  Image rgb, mask;
  int i = 0;
  for (auto _ : state) {
    r.render(cam, m.train[size_t(i++ % 8)], 3, kSynthAll, rgb, mask);
    benchmark::DoNotOptimize(rgb.data.data());
  }
}
BENCHMARK(BM_SynthRenderFrame)->Arg(128)->Arg(512)->Arg(1024)->Unit(benchmark::kMillisecond);

}  // namespace
