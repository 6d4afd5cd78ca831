#include "app/bench_run.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_sweeps.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "core/error.h"
#include "data/dataset.h"
#include "format/avatar_pack.h"
#include "train/device.h"

namespace haha {

namespace fs = std::filesystem;

namespace {

template <class T>
std::vector<T> parse_list(const std::string& text, const char* option) {
  std::vector<T> out;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::istringstream v(item);
    T x{};
    if (!(v >> x) || !v.eof()) fail(option, "expected a comma-separated list of numbers, got '" + text + "'");
    out.push_back(x);
  }
  if (out.empty()) fail(option, "empty list");
  return out;
}

}  // namespace

BenchResult run_bench(const BenchRunOptions& o) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t_start).count(); };
  auto log = [&](const std::string& s) {
    std::printf("[bench %6.1f s] %s\n", elapsed(), s.c_str());
    std::fflush(stdout);
  };
  if (!o.replot.empty()) {
    const BenchResult r = read_bench_json((fs::path(o.replot) / "bench.json").string());
    for (const std::string& p : write_bench_report(o.out.empty() ? o.replot : o.out, r)) log("plot " + p);
    return r;
  }
  if (o.run.empty()) fail("bench", "--run is required (or --replot DIR)");
  if (o.out.empty()) fail("bench", "--out is required");
  const Device device = parse_device(o.device);
  std::set<std::string> skip;
  {
    std::istringstream in(o.skip);
    std::string s;
    while (std::getline(in, s, ','))
      if (!s.empty()) {
        if (s != "training" && s != "filtering" && s != "retrain" && s != "packing" && s != "render")
          fail("--skip", "unknown section '" + s + "' (training, filtering, retrain, packing, render)");
        skip.insert(s);
      }
  }
  if (o.repeats < 1) fail("--repeats", "must be >= 1");
  if (o.tto_steps < 0) fail("--tto-steps", "must be >= 0");
  const std::vector<int> resolutions = parse_list<int>(o.resolutions, "--resolutions");
  for (int r : resolutions)
    if (r < 8 || r > 8192) fail("--resolutions", "image sides must be in 8..8192");
  if (o.count_resolution < 8 || o.count_resolution > 8192) fail("--count-resolution", "must be in 8..8192");

  if (o.retrain_steps < 0) fail("--retrain-steps", "must be >= 0");
  // The run.
  const RunDir run(o.run);
  const RunInfo info = read_trained_run_info(run, "haha bench");
  std::vector<double> thresholds;
  if (!o.thresholds.empty()) {
    thresholds = parse_list<double>(o.thresholds, "--prune-thresholds");
  } else {  // below the trainer's own threshold nothing changes
    thresholds = {info.config.s3.prune_threshold};
    for (double t : {0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9})
      if (t > info.config.s3.prune_threshold) thresholds.push_back(t);
  }
  const std::string data = o.data.empty() ? info.data_path : o.data;
  const Avatar filtered = load_run_avatar(run);
  const Avatar full = load_stage1_avatar(run, filtered.body);
  Dataset ds = read_dataset(data, LoadPixels::headers);
  const Split split = parse_split(o.split, "--split");

  BenchEval ev;
  ev.frames = dataset_frames(ds, split, scoring_resolution(ds, info.config, o.resolution));
  if (ev.frames.empty()) fail(data, "no " + o.split + " frames");
  if (o.frames > 0 && size_t(o.frames) < ev.frames.size()) ev.frames.resize(size_t(o.frames));
  ev.options.tto_steps = o.tto_steps;
  ev.options.lr_pose = info.config.eval_lr_pose;
  ev.options.lr_pose_fine = info.config.eval_lr_pose_fine;
  ev.options.premultiplied = dataset_premultiplied(ds, info.config.premultiplied);

  BenchResult r;
  r.machine = machine_info();
  r.run_dir = o.run;
  r.data_dir = data;
  r.preset = info.config.preset;
  r.device = device_name(device);
  r.date = bench_date();
  r.eval_frames = int(ev.frames.size());
  r.eval_resolution = std::max(ev.frames[0].camera.width, ev.frames[0].camera.height);
  r.tto_steps = o.tto_steps;
  r.stage_seconds = read_train_seconds(run);
  r.stage_steps = {info.config.s1.steps, info.config.s2.steps, info.config.s3.steps};
  if (device == Device::cuda) r.machine.gpu = gpu_description();
  if (r.machine.omp_wait_policy.empty() && r.machine.load_average > 0.5 * r.machine.logical_cpus)
    log("note: other programs are using this machine (load " + std::to_string(r.machine.load_average) +
        ") and OMP_WAIT_POLICY is not set: multi-thread timings will include scheduler waits of spinning "
        "OpenMP threads; OMP_WAIT_POLICY=passive measures them fairly");
  log("machine: " + r.machine.line() + "; run " + o.run + " (" + r.preset + "), " + std::to_string(r.eval_frames) + " " +
      o.split + " frames at " + std::to_string(r.eval_resolution) + " px; " + std::to_string(full.gaussians.size()) +
      " Gaussians after stage 1, " + std::to_string(filtered.gaussians.size()) + " after filtering");
  r.notes.push_back("Quality: PSNR (data range 1) and SSIM over full frames on a black background, " +
                    std::to_string(r.eval_frames) + " " + o.split + " frames of " + data + ", test-time pose optimisation " +
                    (o.tto_steps > 0 ? std::to_string(o.tto_steps) + " steps" : std::string("off (every avatar renders the same poses)")) +
                    "; LPIPS not measured.");
  r.notes.push_back("Storage of the budget sweep: 56 + 4 bytes per Gaussian (float32 parameters + face index, the "
                    "paper's accounting) plus the texture as 8-bit RGB; packed files are measured in the packing section.");
  r.notes.push_back("Render time: LBS + merged mesh/Gaussian render of one frame (CPU: the thread count given, "
                    "median of repeats after a warm-up). On a machine shared with other work, OpenMP threads that "
                    "spin while waiting (OMP_WAIT_POLICY unset or active) lose whole scheduler slices at every "
                    "parallel loop: measured here, 88 ms instead of 6 ms per 128 px frame on 2 threads.");

  auto section = [&](const std::string& name, const std::function<void()>& body) {
    const auto t0 = Clock::now();
    log(name + " ...");
    body();
    r.seconds[name] = std::chrono::duration<double>(Clock::now() - t0).count();
    log(name + " done");
  };

  if (!skip.count("training")) {
    section("training", [&] {
      r.stages = stage_table(filtered, full, r.stage_seconds, ev);
      for (const StageRow& s : r.stages)
        log("  " + s.name + ": " + std::to_string(s.q.gaussians) + " Gaussians, PSNR " + std::to_string(s.q.psnr) + " dB");
    });
    if (r.stage_seconds[0] + r.stage_seconds[1] + r.stage_seconds[2] <= 0)
      r.notes.push_back("The run has no train_summary.json: training times are unknown (0).");
  }
  if (!skip.count("filtering")) {
    section("filtering", [&] {
      r.filtering = sweep_prune_thresholds(filtered, thresholds, ev);
      for (const FilterPoint& p : r.filtering) {
        char line[160];
        std::snprintf(line, sizeof line, "  prune threshold %g: %d Gaussians, PSNR %.2f dB, SSIM %.4f", p.strength,
                      p.q.gaussians, p.q.psnr, p.q.ssim);
        log(line);
      }
      if (skip.count("retrain")) return;
      const std::string ck = run.stage_checkpoint(2);
      if (!fs::exists(ck)) {
        r.notes.push_back("No " + ck + ": stage 3 was not re-run with other opacity weights.");
        log("  no " + ck + ": stage-3 re-runs skipped");
        return;
      }
      const double w0 = info.config.s3.w.opacity;
      std::vector<double> weights;
      if (!o.weights.empty())
        weights = parse_list<double>(o.weights, "--opacity-weights");
      else
        weights = {0.0, 0.1 * w0, w0, 10 * w0, 100 * w0};  // four re-runs: ~1 minute of the tiny bench
      std::sort(weights.begin(), weights.end());
      weights.erase(std::unique(weights.begin(), weights.end()), weights.end());
      const bool full_schedule = o.retrain_steps == 0 || o.retrain_steps == info.config.s3.steps;
      std::vector<double> rerun;
      for (double w : weights) {
        // Training is deterministic: the run's own weight on the full schedule IS the
        // trained avatar (same config, same checkpoint), so it is read off, not re-run.
        if (full_schedule && w == w0 && info.config.use_opacity_reg) {
          FilterPoint p;
          p.method = "opacity weight";
          p.strength = w;
          p.q = evaluate_quality(filtered, ev);
          p.stage3_seconds = r.stage_seconds[2];
          r.filtering.push_back(p);
          log("  opacity weight " + std::to_string(w) + ": the trained avatar");
        } else {
          rerun.push_back(w);
        }
      }
      RetrainSetup setup;
      setup.config = info.config;
      if (!full_schedule) {
        setup.config.s3.steps = o.retrain_steps;
        setup.config.s3.prune_every = std::min(setup.config.s3.prune_every, std::max(1, o.retrain_steps / 4));
      }
      setup.input.body = &filtered.body;
      setup.input.premultiplied = ev.options.premultiplied;
      setup.input.frames = dataset_frames(ds, Split::train, dataset_train_resolution(ds, info.config));
      setup.stage2 = read_checkpoint(ck);
      setup.checkpoint_path = ck;
      const std::vector<FilterPoint> re = sweep_opacity_weights(setup, rerun, ev, log);
      r.filtering.insert(r.filtering.end(), re.begin(), re.end());
      std::stable_sort(r.filtering.begin(), r.filtering.end(), [](const FilterPoint& a, const FilterPoint& b) {
        return a.method != b.method ? a.method > b.method : a.strength < b.strength;  // prune first, then weights
      });
      char note[400];
      std::snprintf(note, sizeof note,
                    "Opacity-weight points re-run stage 3 (%d steps, pruning below %g every %d steps) from the run's "
                    "checkpoint_stage2.npz with only s3.w.opacity changed%s.",
                    setup.config.s3.steps, setup.config.s3.prune_threshold, setup.config.s3.prune_every,
                    full_schedule ? "; the run's own weight is the trained avatar (training is deterministic)" : "");
      r.notes.push_back(note);
    });
  }
  if (!skip.count("packing")) {
    section("packing", [&] {
      std::vector<PackSetting> settings = default_pack_settings(filtered.texture.width);
      std::istringstream sets(o.gaussian_bit_sets);
      for (std::string spec; std::getline(sets, spec, ';');) {
        if (spec.empty()) continue;
        PackSetting p;
        p.name = "Gaussians " + spec;
        p.group = "gaussian allocation";
        p.gaussian_bits_spec = spec;
        p.texture_codec = "png";  // lossless 8-bit: the Gaussians' cost alone
        parse_gaussian_bits(spec, "--gaussian-bit-sets");  // refuse a bad entry before measuring anything
        settings.push_back(p);
      }
      std::istringstream msets(o.mesh_bit_sets);
      for (std::string spec; std::getline(msets, spec, ';');) {
        if (spec.empty()) continue;
        PackSetting p;
        p.name = "mesh " + spec;
        p.group = "mesh allocation";
        p.mesh_bits_spec = spec;
        p.texture_codec = "png";  // lossless 8-bit: the mesh's cost alone
        parse_mesh_bits(spec, "--mesh-bit-sets");  // refuse a bad entry before measuring anything
        settings.push_back(p);
      }
      std::istringstream csets(o.corrective_sets);
      for (std::string spec; std::getline(csets, spec, ';');) {
        if (spec.empty()) continue;
        PackSetting p;
        p.name = "correctives " + spec;
        p.group = "pose correctives";
        p.pose_correctives = spec;
        if (spec != "none" && spec != "dense") parse_pose_corrective_codec(spec, "--corrective-sets");  // refuse a bad entry early
        settings.push_back(p);
      }
      r.packing = sweep_packing(filtered, settings, ev, log);
    });
    r.notes.push_back("Packing: PSNR vs original compares renders of the unpacked .glb with renders of the trained "
                      "avatar on the same poses; the unpacked avatar uses its embedded pose correctives (the "
                      "default: compact) or, where the file has none, the body model's (as `haha render --model` "
                      "does), except for the setting \"correctives none\" (a loader without the body model). "
                      "Pack time: one run; decode time: fastest of 3 runs; both in memory.");
  }
  if (!skip.count("render")) {
    section("render", [&] {
      RenderSweepOptions ro;
      ro.resolutions = resolutions;
      ro.count_resolution = o.count_resolution;
      ro.repeats = o.repeats;
      if (!o.threads.empty()) {
        ro.threads = parse_list<int>(o.threads, "--render-threads");
        for (int t : ro.threads)
          if (t < 1 || t > 1024) fail("--render-threads", "thread counts must be in 1..1024");
      } else {
        const int n = std::max(1, r.machine.logical_cpus);
        ro.threads = n > 1 ? std::vector<int>{1, n} : std::vector<int>{1};
      }
      if (device == Device::cuda) {
        ro.gpu = true;
        r.notes.push_back("GPU: LBS + merged render on the device (avatar buffers uploaded once), synchronised after "
                          "each frame, median of " + std::to_string(o.repeats) + " after a warm-up.");
      }
      r.render = sweep_render_speed(filtered, full, ev.frames[0], ro, log);
    });
  }
  const std::vector<std::string> plots = write_bench_report(o.out, r);
  log("wrote " + (fs::path(o.out) / "bench.json").string() + ", " + (fs::path(o.out) / "bench.md").string());
  for (const std::string& p : plots) log("  plot " + p);
  std::printf("bench: %.1f s on %s\n", elapsed(), r.machine.line().c_str());
  return r;
}

}  // namespace haha
