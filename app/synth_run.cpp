#include "app/synth_run.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <utility>

#include "body/procedural_body.h"
#include "core/error.h"
#include "data/dataset.h"
#include "data/xhumans_take.h"
#include "io/motion.h"

namespace haha {
namespace {

// When run_synth started; a file-level clock because write_synth_dataset's progress
// callback is a plain function pointer.
std::chrono::steady_clock::time_point synth_start;
double seconds() { return std::chrono::duration<double>(std::chrono::steady_clock::now() - synth_start).count(); }

// The motion file's frames kept as `haha render` keeps them (resampled, then thinned).
Motion thinned_motion(const SynthRunOptions& a, const BodyModel& body) {
  Motion m = read_motion(a.motion, &body);
  if (a.rate > 0) m = resample_motion(m, a.rate);
  Motion out = m;
  out.frames.clear();
  out.fps = m.fps / a.every;  // the kept frames' rate, as haha render's video gets
  for (size_t t = 0; t < m.frames.size(); t += size_t(a.every)) {
    if (a.max_frames > 0 && int(out.frames.size()) >= a.max_frames) break;
    out.frames.push_back(m.frames[t]);
  }
  if (out.frames.empty()) fail(a.motion, "no frames");
  return out;
}

}  // namespace

void run_synth(const SynthRunOptions& a) {
  synth_start = std::chrono::steady_clock::now();
  if (!(a.fit_noise >= 0 && a.fit_noise <= 1)) fail("--fit-noise", "must be in [0, 1]");
  if (a.every <= 0) fail("--every", "must be positive");
  if (a.max_frames < 0) fail("--max-frames", "must be 0 (all) or positive");
  if (a.rate < 0 || !std::isfinite(a.rate) || a.rate > 10000) fail("--rate", "must be in (0, 10000] frames per second");
  SynthOptions o = a.synth;
  o.fit_noise.pose = a.fit_noise_pose.value_or(a.fit_noise);
  o.fit_noise.transl = a.fit_noise_transl.value_or(a.fit_noise);
  {
    SynthOptions checked = o;  // cheap checks before any work
    if (!a.motion.empty()) {  // the frame counts come from the motion
      checked.train_frames = 1;
      checked.test_frames = 0;
    }
    validate_synth_options(checked);
  }
  if (a.resolution != "low" && a.resolution != "full")
    fail("--body-resolution", "unknown value '" + a.resolution + "' (expected low or full)");
  const BodyModel body = synth_body(a.body, parse_body_resolution(a.resolution), o.seed);
  std::printf("  body: %d vertices (%s), %.2f s\n", body.num_verts, body.source.c_str(), seconds());
  auto log = [](const std::string& line) { std::printf("  %s, %.2f s\n", line.c_str(), seconds()); };
  SynthSummary s;
  if (!a.motion.empty()) {
    const Motion m = thinned_motion(a, body);
    std::printf("  motion %s: %zu frames, %.2f s\n", a.motion.c_str(), m.frames.size(), seconds());
    s = write_synth_motion_dataset(a.out, body, o, m, a.body.empty(), a.part_masks, log);
  } else {
    s = write_synth_dataset(a.out, body, o, a.body.empty(), log, a.part_masks);
  }
  if (!a.xhumans.empty()) {
    Dataset ds = read_dataset(a.out, LoadPixels::headers);
    for (auto [split, take] : {std::pair{Split::train, "train/Take1"}, std::pair{Split::test, "test/Take2"}}) {
      if (ds.indices(split).empty()) continue;
      write_xhumans_take(ds, split, body, a.xhumans + "/" + take);
      std::printf("  X-Humans take %s/%s, %.2f s\n", a.xhumans.c_str(), take, seconds());
    }
  }
  if (!a.motion.empty())
    std::printf("%s: %d test frames in the poses of %s, %dx%d, f = %.1f px, %.2f s\n", a.out.c_str(), s.test_frames,
                a.motion.c_str(), o.size, o.size, double(s.camera.fx), seconds());
  else
    std::printf("%s: %d train + %d test%s frames, %dx%d, f = %.1f px, min test-train pose gap %.2f rad, %.2f s\n",
                a.out.c_str(), s.train_frames, s.test_frames,
                s.unseen_frames > 0 ? (" + " + std::to_string(s.unseen_frames) + " unseen").c_str() : "", o.size,
                o.size, double(s.camera.fx), s.min_pose_gap, seconds());
}

}  // namespace haha
