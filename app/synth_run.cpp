#include "app/synth_run.h"

#include <chrono>
#include <cstdio>
#include <utility>

#include "body/procedural_body.h"
#include "core/error.h"
#include "data/dataset.h"
#include "data/xhumans_take.h"

namespace haha {
namespace {

// When run_synth started; a file-level clock because write_synth_dataset's progress
// callback is a plain function pointer.
std::chrono::steady_clock::time_point synth_start;
double seconds() { return std::chrono::duration<double>(std::chrono::steady_clock::now() - synth_start).count(); }

}  // namespace

void run_synth(const SynthRunOptions& a) {
  synth_start = std::chrono::steady_clock::now();
  if (!(a.fit_noise >= 0 && a.fit_noise <= 1)) fail("--fit-noise", "must be in [0, 1]");
  SynthOptions o = a.synth;
  o.fit_noise.pose = a.fit_noise_pose.value_or(a.fit_noise);
  o.fit_noise.transl = a.fit_noise_transl.value_or(a.fit_noise);
  validate_synth_options(o);  // cheap checks before any work
  if (a.resolution != "low" && a.resolution != "full")
    fail("--body-resolution", "unknown value '" + a.resolution + "' (expected low or full)");
  const BodyModel body = synth_body(a.body, parse_body_resolution(a.resolution), o.seed);
  std::printf("  body: %d vertices (%s), %.2f s\n", body.num_verts, body.source.c_str(), seconds());
  const SynthSummary s = write_synth_dataset(a.out, body, o, a.body.empty(), [](const std::string& line) {
    std::printf("  %s, %.2f s\n", line.c_str(), seconds());
  });
  if (!a.xhumans.empty()) {
    Dataset ds = read_dataset(a.out, LoadPixels::headers);
    for (auto [split, take] : {std::pair{Split::train, "train/Take1"}, std::pair{Split::test, "test/Take2"}}) {
      if (ds.indices(split).empty()) continue;
      write_xhumans_take(ds, split, body, a.xhumans + "/" + take);
      std::printf("  X-Humans take %s/%s, %.2f s\n", a.xhumans.c_str(), take, seconds());
    }
  }
  std::printf("%s: %d train + %d test frames, %dx%d, f = %.1f px, min test-train pose gap %.2f rad, %.2f s\n",
              a.out.c_str(), s.train_frames, s.test_frames, o.size, o.size, double(s.camera.fx), s.min_pose_gap, seconds());
}

}  // namespace haha
