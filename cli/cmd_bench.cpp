// `haha bench`: speed and size against error on one trained run (data/bench_sweeps.h):
// the stage table with training wall times, the Gaussian budget (stage 3 re-run with
// several opacity-regulariser weights, and pruning thresholds), packing settings, and
// render speed against resolution / Gaussian count / threads. Writes OUT/bench.json,
// OUT/bench.md and OUT/plots/*.png (data/bench_report.h).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "core/device.h"
#include "core/error.h"
#include "core/parallel.h"
#include "data/bench_report.h"
#include "data/bench_sweeps.h"
#include "data/dataset.h"
#include "data/train_run.h"
#include "format/avatar_npz.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/image_codec.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
#include "cuda/avatar_render_cuda.h"
#include "cuda/lbs_cuda.h"
#include "cuda/runtime.h"
#endif

namespace {

template <class T>
std::vector<T> parse_list(const std::string& text, const char* option) {
  std::vector<T> out;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::istringstream v(item);
    T x{};
    if (!(v >> x) || !v.eof()) haha::fail(option, "expected a comma-separated list of numbers, got '" + text + "'");
    out.push_back(x);
  }
  if (out.empty()) haha::fail(option, "empty list");
  return out;
}

// The format layer's packer for the bench (data/ does not link format/).
haha::PackCodec format_codec() {
  haha::PackCodec c;
  c.pack = [](const haha::Avatar& a, const haha::PackSetting& s, haha::PackedBytes& bytes) {
    haha::PackOptions o;
    o.lossless = s.lossless;
    if (s.gaussian_bits >= 0) {
      haha::GaussianBits& g = o.gaussian_bits;
      g.offset = g.rotation = g.scale = g.color = g.opacity = s.gaussian_bits;
    }
    o.texture_codec = haha::texture_codec_from_name(s.texture_codec);
    o.texture_quality = s.texture_quality;
    o.texture_size = s.texture_size;
    haha::PackedSizes sz;
    std::vector<uint8_t> b = haha::pack_avatar(a, o, &sz);
    bytes.total = b.size();
    bytes.gaussians = sz.gaussians;
    bytes.texture = sz.texture + sz.texture_exact;
    bytes.mesh = sz.mesh + sz.skeleton;
    return b;
  };
  c.unpack = [](const std::vector<uint8_t>& b) { return haha::unpack_avatar(b.data(), b.size(), "bench").avatar; };
  return c;
}

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
// GPU time of one frame: LBS + the merged render on the device (cuda/avatar_render_cuda.h),
// the avatar's buffers uploaded once beforehand; median of `repeats` after a warm-up,
// each ending with a device synchronisation.
double gpu_render_ms(const haha::Avatar& a, const haha::Camera& cam, const haha::SmplxParams& p, int repeats) {
  namespace hc = haha::cuda;
  hc::LbsCuda lbs(a.body);
  const hc::AvatarBodyCuda body(a.body);
  hc::DeviceBuffer<float> verts(size_t(a.body.num_verts) * 3);
  const haha::BoundGaussians& g = a.gaussians;
  const hc::DeviceBuffer<int32_t> face(g.face);
  const hc::DeviceBuffer<float> off(g.offset), rot(g.rotation), sc(g.scale), col(g.color), op(g.opacity), tex(a.texture.rgb);
  const haha::GaussianSetView gv{g.size(), face.data(), off.data(), rot.data(), sc.data(), col.data(), op.data()};
  const haha::TextureView tv{a.texture.width, a.texture.height, 3, tex.data()};
  hc::AvatarRenderCudaRequest req;
  req.camera = &cam;
  req.body = &body;
  req.verts = verts.data();
  req.face_scale_divisor = a.face_scale_divisor;
  req.gaussians = g.size() > 0 ? &gv : nullptr;
  req.texture = &tv;
  hc::AvatarRenderCudaBuffers buf;
  const haha::SmplxView<float> v{p.pose.data(), p.betas.data(), int(p.betas.size()), p.expression.data(),
                                 int(p.expression.size()), p.transl.data()};
  auto once = [&] {
    const auto t0 = std::chrono::steady_clock::now();
    lbs.forward(v, verts.data(), nullptr, nullptr);
    hc::render_avatar_cuda(req, buf);
    hc::synchronize("bench render");
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  once();
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) t.push_back(once());
  std::sort(t.begin(), t.end());
  return t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
}
#endif

}  // namespace

HAHA_COMMAND(bench) {
  struct Opts {
    std::string run, data, out, device = "cpu", split = "test", skip, replot;
    std::string weights, thresholds, resolutions = "128,256,512,1024", threads;
    int frames = 0, tto_steps = 0, repeats = 5, count_resolution = 512, retrain_steps = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("bench", "Speed and size against error on a trained run: bench.json, bench.md, PNG plots");
  sub->add_option("--run", o->run, "run directory (haha train --out; haha eval not needed)");
  sub->add_option("--replot", o->replot,
                  "redraw bench.md and the plots of an earlier bench directory from its bench.json (no measuring)");
  sub->add_option("--data", o->data, "dataset directory (default: the run's)");
  sub->add_option("--out", o->out, "output directory");
  sub->add_option("--device", o->device, "cpu or cuda (render timings also on the GPU)")->capture_default_str();
  sub->add_option("--split", o->split, "frames the quality numbers are measured on: test or train")->capture_default_str();
  sub->add_option("--frames", o->frames, "use only the first N frames of the split (0 = all)");
  sub->add_option("--tto-steps", o->tto_steps,
                  "test-time pose optimisation steps per frame and avatar (0: every avatar on the same poses)")
      ->capture_default_str();
  sub->add_option("--opacity-weights", o->weights,
                  "stage-3 opacity-regulariser weights to re-run stage 3 with (default: 0 and the run's weight w x 0.1, 1, 10, "
                  "100; w itself is read off the trained avatar, not re-run)");
  sub->add_option("--retrain-steps", o->retrain_steps,
                  "stage-3 steps of the re-runs (default: the run's; a shorter stage 3 re-runs the run's weight too)");
  sub->add_option("--prune-thresholds", o->thresholds,
                  "opacity thresholds for pruning the trained avatar (default: the run's s3.prune_threshold, then 0.15 .. 0.9)");
  sub->add_option("--resolutions", o->resolutions, "image sides of the render-speed sweep")->capture_default_str();
  sub->add_option("--count-resolution", o->count_resolution, "image side of the Gaussian-count sweep")->capture_default_str();
  sub->add_option("--render-threads", o->threads, "CPU thread counts of the render sweep (default: 1 and all)");
  sub->add_option("--repeats", o->repeats, "timed renders per point (median reported)")->capture_default_str();
  sub->add_option("--skip", o->skip, "sections to leave out: training,filtering,retrain,packing,render");
  sub->callback([o] {
    namespace fs = std::filesystem;
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t_start).count(); };
    auto log = [&](const std::string& s) {
      std::printf("[bench %6.1f s] %s\n", elapsed(), s.c_str());
      std::fflush(stdout);
    };
    if (!o->replot.empty()) {
      const haha::BenchResult r = haha::read_bench_json((fs::path(o->replot) / "bench.json").string());
      for (const std::string& p : haha::write_bench_report(o->out.empty() ? o->replot : o->out, r)) log("plot " + p);
      return;
    }
    if (o->run.empty()) haha::fail("bench", "--run is required (or --replot DIR)");
    if (o->out.empty()) haha::fail("bench", "--out is required");
    const haha::Device device = haha::parse_device(o->device);
    std::set<std::string> skip;
    {
      std::istringstream in(o->skip);
      std::string s;
      while (std::getline(in, s, ','))
        if (!s.empty()) {
          if (s != "training" && s != "filtering" && s != "retrain" && s != "packing" && s != "render")
            haha::fail("--skip", "unknown section '" + s + "' (training, filtering, retrain, packing, render)");
          skip.insert(s);
        }
    }
    if (o->repeats < 1) haha::fail("--repeats", "must be >= 1");
    if (o->tto_steps < 0) haha::fail("--tto-steps", "must be >= 0");
    const std::vector<int> resolutions = parse_list<int>(o->resolutions, "--resolutions");
    for (int r : resolutions)
      if (r < 8 || r > 8192) haha::fail("--resolutions", "image sides must be in 8..8192");
    if (o->count_resolution < 8 || o->count_resolution > 8192) haha::fail("--count-resolution", "must be in 8..8192");

    if (o->retrain_steps < 0) haha::fail("--retrain-steps", "must be >= 0");
    // The run.
    const haha::RunInfo info = haha::read_run_info((fs::path(o->run) / "config.json").string());
    std::vector<double> thresholds;
    if (!o->thresholds.empty()) {
      thresholds = parse_list<double>(o->thresholds, "--prune-thresholds");
    } else {  // below the trainer's own threshold nothing changes
      thresholds = {info.config.s3.prune_threshold};
      for (double t : {0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9})
        if (t > info.config.s3.prune_threshold) thresholds.push_back(t);
    }
    const std::string data = o->data.empty() ? info.data_path : o->data;
    const haha::Avatar filtered = haha::load_run_avatar(o->run);
    haha::Avatar full = haha::load_avatar_npz((fs::path(o->run) / "avatar_stage1.npz").string());
    full.body = filtered.body;
    haha::Dataset ds = haha::read_dataset(data, haha::LoadPixels::headers);
    const haha::Split split = haha::parse_split(o->split, "--split");

    haha::BenchEval ev;
    ev.frames = haha::dataset_frames(ds, split, info.config.resolution);
    if (ev.frames.empty()) haha::fail(data, "no " + o->split + " frames");
    if (o->frames > 0 && size_t(o->frames) < ev.frames.size()) ev.frames.resize(size_t(o->frames));
    ev.options.tto_steps = o->tto_steps;
    ev.options.lr_pose = info.config.eval_lr_pose;
    ev.options.lr_pose_fine = info.config.eval_lr_pose_fine;
    ev.options.premultiplied = haha::dataset_premultiplied(ds, info.config.premultiplied);

    haha::BenchResult r;
    r.machine = haha::machine_info();
    r.run_dir = o->run;
    r.data_dir = data;
    r.preset = info.config.preset;
    r.device = haha::device_name(device);
    r.date = haha::bench_date();
    r.eval_frames = int(ev.frames.size());
    r.eval_resolution = std::max(ev.frames[0].camera.width, ev.frames[0].camera.height);
    r.tto_steps = o->tto_steps;
    r.stage_seconds = haha::read_train_seconds(o->run);
    r.stage_steps = {info.config.s1.steps, info.config.s2.steps, info.config.s3.steps};
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
    if (device == haha::Device::cuda) r.machine.gpu = haha::cuda::device_description();
#endif
    if (r.machine.omp_wait_policy.empty() && r.machine.load_average > 0.5 * r.machine.logical_cpus)
      log("note: other programs are using this machine (load " + std::to_string(r.machine.load_average) +
          ") and OMP_WAIT_POLICY is not set: multi-thread timings will include scheduler waits of spinning "
          "OpenMP threads; OMP_WAIT_POLICY=passive measures them fairly");
    log("machine: " + r.machine.line() + "; run " + o->run + " (" + r.preset + "), " + std::to_string(r.eval_frames) + " " +
        o->split + " frames at " + std::to_string(r.eval_resolution) + " px; " + std::to_string(full.gaussians.size()) +
        " Gaussians after stage 1, " + std::to_string(filtered.gaussians.size()) + " after filtering");
    r.notes.push_back("Quality: PSNR (data range 1) and SSIM over full frames on a black background, " +
                      std::to_string(r.eval_frames) + " " + o->split + " frames of " + data + ", test-time pose optimisation " +
                      (o->tto_steps > 0 ? std::to_string(o->tto_steps) + " steps" : std::string("off (every avatar renders the same poses)")) +
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
        r.stages = haha::stage_table(filtered, full, r.stage_seconds, ev);
        for (const haha::StageRow& s : r.stages)
          log("  " + s.name + ": " + std::to_string(s.q.gaussians) + " Gaussians, PSNR " + std::to_string(s.q.psnr) + " dB");
      });
      if (r.stage_seconds[0] + r.stage_seconds[1] + r.stage_seconds[2] <= 0)
        r.notes.push_back("The run has no train_summary.json: training times are unknown (0).");
    }
    if (!skip.count("filtering")) {
      section("filtering", [&] {
        r.filtering = haha::sweep_prune_thresholds(filtered, thresholds, ev);
        for (const haha::FilterPoint& p : r.filtering) {
          char line[160];
          std::snprintf(line, sizeof line, "  prune threshold %g: %d Gaussians, PSNR %.2f dB, SSIM %.4f", p.strength,
                        p.q.gaussians, p.q.psnr, p.q.ssim);
          log(line);
        }
        if (skip.count("retrain")) return;
        const std::string ck = (fs::path(o->run) / "checkpoint_stage2.npz").string();
        if (!fs::exists(ck)) {
          r.notes.push_back("No " + ck + ": stage 3 was not re-run with other opacity weights.");
          log("  no " + ck + ": stage-3 re-runs skipped");
          return;
        }
        const double w0 = info.config.s3.w.opacity;
        std::vector<double> weights;
        if (!o->weights.empty())
          weights = parse_list<double>(o->weights, "--opacity-weights");
        else
          weights = {0.0, 0.1 * w0, w0, 10 * w0, 100 * w0};  // four re-runs: ~1 minute of the tiny bench
        std::sort(weights.begin(), weights.end());
        weights.erase(std::unique(weights.begin(), weights.end()), weights.end());
        const bool full_schedule = o->retrain_steps == 0 || o->retrain_steps == info.config.s3.steps;
        std::vector<double> rerun;
        for (double w : weights) {
          // Training is deterministic: the run's own weight on the full schedule IS the
          // trained avatar (same config, same checkpoint), so it is read off, not re-run.
          if (full_schedule && w == w0 && info.config.use_opacity_reg) {
            haha::FilterPoint p;
            p.method = "opacity weight";
            p.strength = w;
            p.q = haha::evaluate_quality(filtered, ev);
            p.stage3_seconds = r.stage_seconds[2];
            r.filtering.push_back(p);
            log("  opacity weight " + std::to_string(w) + ": the trained avatar");
          } else {
            rerun.push_back(w);
          }
        }
        haha::RetrainSetup setup;
        setup.config = info.config;
        if (!full_schedule) {
          setup.config.s3.steps = o->retrain_steps;
          setup.config.s3.prune_every = std::min(setup.config.s3.prune_every, std::max(1, o->retrain_steps / 4));
        }
        setup.input.body = &filtered.body;
        setup.input.premultiplied = ev.options.premultiplied;
        setup.input.frames = haha::dataset_frames(ds, haha::Split::train, info.config.resolution);
        setup.stage2 = haha::read_checkpoint(ck);
        setup.checkpoint_path = ck;
        const std::vector<haha::FilterPoint> re = haha::sweep_opacity_weights(setup, rerun, ev, log);
        r.filtering.insert(r.filtering.end(), re.begin(), re.end());
        std::stable_sort(r.filtering.begin(), r.filtering.end(), [](const haha::FilterPoint& a, const haha::FilterPoint& b) {
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
        const haha::PackOptions defaults;
        r.packing = haha::sweep_packing(
            filtered,
            haha::default_pack_settings(filtered.texture.width, haha::texture_extension(defaults.texture_codec),
                                        defaults.texture_quality),
            format_codec(), ev, log);
      });
      r.notes.push_back("Packing: PSNR vs original compares renders of the unpacked .glb with renders of the trained "
                        "avatar on the same poses; the unpacked avatar uses the body model's pose correctives (as "
                        "`haha render --model` does), so only quantization and texture coding are measured. "
                        "Pack time: one run; decode time: fastest of 3 runs; both in memory.");
    }
    if (!skip.count("render")) {
      section("render", [&] {
        haha::RenderSweepOptions ro;
        ro.resolutions = resolutions;
        ro.count_resolution = o->count_resolution;
        ro.repeats = o->repeats;
        if (!o->threads.empty()) {
          ro.threads = parse_list<int>(o->threads, "--render-threads");
          for (int t : ro.threads)
            if (t < 1 || t > 1024) haha::fail("--render-threads", "thread counts must be in 1..1024");
        } else {
          const int n = std::max(1, r.machine.logical_cpus);
          ro.threads = n > 1 ? std::vector<int>{1, n} : std::vector<int>{1};
        }
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
        if (device == haha::Device::cuda) {
          ro.gpu = gpu_render_ms;
          r.notes.push_back("GPU: LBS + merged render on the device (avatar buffers uploaded once), synchronised after "
                            "each frame, median of " + std::to_string(o->repeats) + " after a warm-up.");
        }
#endif
        r.render = haha::sweep_render_speed(filtered, full, ev.frames[0], ro, log);
      });
    }
    const std::vector<std::string> plots = haha::write_bench_report(o->out, r);
    log("wrote " + (fs::path(o->out) / "bench.json").string() + ", " + (fs::path(o->out) / "bench.md").string());
    for (const std::string& p : plots) log("  plot " + p);
    std::printf("bench: %.1f s on %s\n", elapsed(), r.machine.line().c_str());
  });
}
