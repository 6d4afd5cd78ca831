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

using LogFn = std::function<void(const std::string&)>;

// The sections `--skip` names, each checked.
std::set<std::string> parse_skip(const std::string& text) {
  std::set<std::string> skip;
  std::istringstream in(text);
  std::string s;
  while (std::getline(in, s, ','))
    if (!s.empty()) {
      if (s != "training" && s != "filtering" && s != "retrain" && s != "packing" && s != "render")
        fail("--skip", "unknown section '" + s + "' (training, filtering, retrain, packing, render)");
      skip.insert(s);
    }
  return skip;
}

// The options checked before the run is read (those of one section are checked in it).
struct CheckedOptions {
  Device device = Device::cpu;
  std::set<std::string> skip;
  std::vector<int> resolutions;
};

CheckedOptions check_options(const BenchRunOptions& o) {
  if (o.run.empty()) fail("bench", "--run is required (or --replot DIR)");
  if (o.out.empty()) fail("bench", "--out is required");
  CheckedOptions c;
  c.device = parse_device(o.device);
  c.skip = parse_skip(o.skip);
  if (o.repeats < 1) fail("--repeats", "must be >= 1");
  if (o.tto_steps < 0) fail("--tto-steps", "must be >= 0");
  c.resolutions = parse_list<int>(o.resolutions, "--resolutions");
  for (int r : c.resolutions)
    if (r < 8 || r > 8192) fail("--resolutions", "image sides must be in 8..8192");
  if (o.count_resolution < 8 || o.count_resolution > 8192) fail("--count-resolution", "must be in 8..8192");

  if (o.retrain_steps < 0) fail("--retrain-steps", "must be >= 0");
  return c;
}

std::vector<double> prune_thresholds(const BenchRunOptions& o, const RunInfo& info) {
  if (!o.thresholds.empty()) return parse_list<double>(o.thresholds, "--prune-thresholds");
  // Below the trainer's own threshold nothing changes.
  std::vector<double> thresholds = {info.config.s3.prune_threshold};
  for (double t : {0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9})
    if (t > info.config.s3.prune_threshold) thresholds.push_back(t);
  return thresholds;
}

// The frames every quality number is measured on, and how.
BenchEval bench_eval(const BenchRunOptions& o, const RunInfo& info, Dataset& ds, const std::string& data) {
  const Split split = parse_split(o.split, "--split");
  BenchEval ev;
  ev.frames = dataset_frames(ds, split, scoring_resolution(ds, info.config, o.resolution));
  if (ev.frames.empty()) fail(data, "no " + o.split + " frames");
  if (o.frames > 0 && size_t(o.frames) < ev.frames.size()) ev.frames.resize(size_t(o.frames));
  ev.options.tto_steps = o.tto_steps;
  ev.options.lr_pose = info.config.eval_lr_pose;
  ev.options.lr_pose_fine = info.config.eval_lr_pose_fine;
  ev.options.premultiplied = dataset_premultiplied(ds, info.config.premultiplied);
  return ev;
}

// What the sections measure: the trained run, its two avatars and the frames they are scored on.
struct BenchInputs {
  const BenchRunOptions& o;
  const RunDir& run;
  const RunInfo& info;
  const Avatar& filtered;
  const Avatar& full;
  Dataset& ds;
  const BenchEval& ev;
  const LogFn& log;
};

void add_method_notes(const BenchInputs& in, const std::string& data, BenchResult& r) {
  r.notes.push_back("Quality: PSNR (data range 1) and SSIM over full frames on a black background, " +
                    std::to_string(r.eval_frames) + " " + in.o.split + " frames of " + data + ", test-time pose optimisation " +
                    (in.o.tto_steps > 0 ? std::to_string(in.o.tto_steps) + " steps" : std::string("off (every avatar renders the same poses)")) +
                    "; LPIPS not measured.");
  r.notes.push_back("Storage of the budget sweep: 56 + 4 bytes per Gaussian (float32 parameters + face index, the "
                    "paper's accounting) plus the texture as 8-bit RGB; packed files are measured in the packing section.");
  r.notes.push_back("Render time: LBS + merged mesh/Gaussian render of one frame (CPU: the thread count given, "
                    "median of repeats after a warm-up). On a machine shared with other work, OpenMP threads that "
                    "spin while waiting (OMP_WAIT_POLICY unset or active) lose whole scheduler slices at every "
                    "parallel loop: measured here, 88 ms instead of 6 ms per 128 px frame on 2 threads.");
}

// The result's header (machine, run, frames) and notes, with the lines that say them.
BenchResult start_result(const BenchInputs& in, Device device, const std::string& data) {
  const BenchRunOptions& o = in.o;
  BenchResult r;
  r.machine = machine_info();
  r.run_dir = o.run;
  r.data_dir = data;
  r.preset = in.info.config.preset;
  r.device = device_name(device);
  r.date = bench_date();
  r.eval_frames = int(in.ev.frames.size());
  r.eval_resolution = std::max(in.ev.frames[0].camera.width, in.ev.frames[0].camera.height);
  r.tto_steps = o.tto_steps;
  r.stage_seconds = read_train_seconds(in.run);
  r.stage_steps = {in.info.config.s1.steps, in.info.config.s2.steps, in.info.config.s3.steps};
  if (device == Device::cuda) r.machine.gpu = gpu_description();
  if (r.machine.omp_wait_policy.empty() && r.machine.load_average > 0.5 * r.machine.logical_cpus)
    in.log("note: other programs are using this machine (load " + std::to_string(r.machine.load_average) +
           ") and OMP_WAIT_POLICY is not set: multi-thread timings will include scheduler waits of spinning "
           "OpenMP threads; OMP_WAIT_POLICY=passive measures them fairly");
  in.log("machine: " + r.machine.line() + "; run " + o.run + " (" + r.preset + "), " + std::to_string(r.eval_frames) + " " +
         o.split + " frames at " + std::to_string(r.eval_resolution) + " px; " + std::to_string(in.full.gaussians.size()) +
         " Gaussians after stage 1, " + std::to_string(in.filtered.gaussians.size()) + " after filtering");
  add_method_notes(in, data, r);
  return r;
}

void training_section(const BenchInputs& in, BenchResult& r) {
  r.stages = stage_table(in.filtered, in.full, r.stage_seconds, in.ev);
  for (const StageRow& s : r.stages)
    in.log("  " + s.name + ": " + std::to_string(s.q.gaussians) + " Gaussians, PSNR " + std::to_string(s.q.psnr) + " dB");
}

// The values a stage-3 re-run sweeps: --opacity-weights as given; else around the run's own
// value v0 of its knob (the opacity weight, or the image cost of a run filtering by it).
std::vector<double> stage3_values(const BenchRunOptions& o, Stage3Knob knob, double v0) {
  std::vector<double> v;
  if (!o.weights.empty())
    v = parse_list<double>(o.weights, "--opacity-weights");
  else if (knob == Stage3Knob::opacity_weight)
    v = {0.0, 0.1 * v0, v0, 10 * v0, 100 * v0};  // four re-runs: ~1 minute of the tiny bench
  else
    v = {0.2 * v0, 0.5 * v0, v0, 2 * v0, 5 * v0};
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

// Stage 3 again from the run's stage-2 checkpoint `ck`, with only the opacity weight changed,
// or for a run that filters by the image (s3.prune_cost, no opacity weight) only its image cost.
void rerun_stage3(const BenchInputs& in, const std::string& ck, BenchResult& r) {
  const BenchRunOptions& o = in.o;
  const TrainConfig& config = in.info.config;
  const bool by_image = o.weights.empty() && config.s3.prune_cost > 0 && config.s3.w.opacity == 0;
  const Stage3Knob knob = by_image ? Stage3Knob::image_cost : Stage3Knob::opacity_weight;
  const std::string method = stage3_knob_method(knob);
  const double v0 = by_image ? config.s3.prune_cost : config.s3.w.opacity;
  const bool full_schedule = o.retrain_steps == 0 || o.retrain_steps == config.s3.steps;
  std::vector<double> rerun;
  for (double w : stage3_values(o, knob, v0)) {
    // Training is deterministic: the run's own value on the full schedule IS the trained
    // avatar (same config, same checkpoint), so it is read off, not re-run.
    if (full_schedule && w == v0 && (by_image || config.use_opacity_reg)) {
      FilterPoint p;
      p.method = method;
      p.strength = w;
      p.q = evaluate_quality(in.filtered, in.ev);
      p.stage3_seconds = r.stage_seconds[2];
      r.filtering.push_back(p);
      in.log("  " + method + " " + std::to_string(w) + ": the trained avatar");
    } else {
      rerun.push_back(w);
    }
  }
  RetrainSetup setup;
  setup.config = config;
  if (!full_schedule) {
    setup.config.s3.steps = o.retrain_steps;
    setup.config.s3.prune_every = std::min(setup.config.s3.prune_every, std::max(1, o.retrain_steps / 4));
  }
  setup.input.body = &in.filtered.body;
  setup.input.premultiplied = in.ev.options.premultiplied;
  setup.input.frames = dataset_frames(in.ds, Split::train, dataset_train_resolution(in.ds, config));
  setup.stage2 = read_checkpoint(ck);
  setup.checkpoint_path = ck;
  const std::vector<FilterPoint> re = sweep_stage3(setup, knob, rerun, in.ev, in.log);
  r.filtering.insert(r.filtering.end(), re.begin(), re.end());
  std::stable_sort(r.filtering.begin(), r.filtering.end(), [](const FilterPoint& a, const FilterPoint& b) {
    return a.method != b.method ? a.method > b.method : a.strength < b.strength;  // prune first, then re-runs
  });
  char note[400];
  std::snprintf(note, sizeof note,
                "%s points re-run stage 3 (%d steps, pruning below %g every %d steps) from the run's "
                "checkpoint_stage2.npz with only %s changed%s.",
                by_image ? "Image-cost" : "Opacity-weight", setup.config.s3.steps, setup.config.s3.prune_threshold,
                setup.config.s3.prune_every, by_image ? "s3.prune_cost" : "s3.w.opacity",
                full_schedule ? "; the run's own value is the trained avatar (training is deterministic)" : "");
  r.notes.push_back(note);
}

void filtering_section(const BenchInputs& in, const std::vector<double>& thresholds, bool retrain, BenchResult& r) {
  r.filtering = sweep_prune_thresholds(in.filtered, thresholds, in.ev);
  for (const FilterPoint& p : r.filtering) {
    char line[160];
    std::snprintf(line, sizeof line, "  prune threshold %g: %d Gaussians, PSNR %.2f dB, SSIM %.4f", p.strength,
                  p.q.gaussians, p.q.psnr, p.q.ssim);
    in.log(line);
  }
  if (!retrain) return;
  const std::string ck = in.run.stage_checkpoint(2);
  if (!fs::exists(ck)) {
    r.notes.push_back("No " + ck + ": stage 3 was not re-run with other opacity weights.");
    in.log("  no " + ck + ": stage-3 re-runs skipped");
    return;
  }
  rerun_stage3(in, ck, r);
}

// The default settings plus the extra points of --gaussian-bit-sets, --mesh-bit-sets and
// --corrective-sets.
std::vector<PackSetting> pack_settings(const BenchRunOptions& o, const Avatar& filtered) {
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
  return settings;
}

void render_section(const BenchInputs& in, const std::vector<int>& resolutions, Device device, BenchResult& r) {
  const BenchRunOptions& o = in.o;
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
  r.render = sweep_render_speed(in.filtered, in.full, in.ev.frames[0], ro, in.log);
}

}  // namespace

BenchResult run_bench(const BenchRunOptions& o) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t_start).count(); };
  const LogFn log = [&](const std::string& s) {
    std::printf("[bench %6.1f s] %s\n", elapsed(), s.c_str());
    std::fflush(stdout);
  };
  if (!o.replot.empty()) {
    const BenchResult r = read_bench_json((fs::path(o.replot) / "bench.json").string());
    for (const std::string& p : write_bench_report(o.out.empty() ? o.replot : o.out, r)) log("plot " + p);
    return r;
  }
  const CheckedOptions c = check_options(o);
  // The run.
  const RunDir run(o.run);
  const RunInfo info = read_trained_run_info(run, "haha bench");
  const std::vector<double> thresholds = prune_thresholds(o, info);
  const std::string data = o.data.empty() ? info.data_path : o.data;
  const Avatar filtered = load_run_avatar(run);
  const Avatar full = load_stage1_avatar(run, filtered.body);
  Dataset ds = read_dataset(data, LoadPixels::headers);
  const BenchEval ev = bench_eval(o, info, ds, data);
  const BenchInputs in{o, run, info, filtered, full, ds, ev, log};
  BenchResult r = start_result(in, c.device, data);

  auto section = [&](const std::string& name, const std::function<void()>& body) {
    const auto t0 = Clock::now();
    log(name + " ...");
    body();
    r.seconds[name] = std::chrono::duration<double>(Clock::now() - t0).count();
    log(name + " done");
  };
  if (!c.skip.count("training")) {
    section("training", [&] { training_section(in, r); });
    if (r.stage_seconds[0] + r.stage_seconds[1] + r.stage_seconds[2] <= 0)
      r.notes.push_back("The run has no train_summary.json: training times are unknown (0).");
  }
  if (!c.skip.count("filtering"))
    section("filtering", [&] { filtering_section(in, thresholds, !c.skip.count("retrain"), r); });
  if (!c.skip.count("packing")) {
    section("packing", [&] { r.packing = sweep_packing(filtered, pack_settings(o, filtered), ev, log); });
    r.notes.push_back("Packing: PSNR vs original compares renders of the unpacked .glb with renders of the trained "
                      "avatar on the same poses; the unpacked avatar uses its embedded pose correctives (the "
                      "default: compact) or, where the file has none, the body model's (as `haha render --model` "
                      "does), except for the setting \"correctives none\" (a loader without the body model). "
                      "Pack time: one run; decode time: fastest of 3 runs; both in memory.");
  }
  if (!c.skip.count("render")) section("render", [&] { render_section(in, c.resolutions, c.device, r); });
  const std::vector<std::string> plots = write_bench_report(o.out, r);
  log("wrote " + (fs::path(o.out) / "bench.json").string() + ", " + (fs::path(o.out) / "bench.md").string());
  for (const std::string& p : plots) log("  plot " + p);
  std::printf("bench: %.1f s on %s\n", elapsed(), r.machine.line().c_str());
  return r;
}

}  // namespace haha
