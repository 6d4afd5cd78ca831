// train_bench: the end-to-end training benchmark. It builds the synthetic subject in memory
// (what `haha synth` writes, its frames rounded to 8 bits as the dataset's PNGs hold them),
// trains the three HAHA stages as `haha train` does on that dataset, times them, and
// evaluates mesh only / full Gaussians / HAHA on the test frames as `haha eval` does
// (CPU, without test-time pose optimisation). It links no I/O library, so it builds with
// HAHA_WITH_IO=OFF on a machine that has only the compiler, OpenMP and CUDA.
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "body/procedural_body.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/parallel.h"
#include "synth/synth_subject.h"
#include "train/config.h"
#include "train/device.h"
#include "train/evaluate.h"
#include "train/silhouette_fit.h"
#include "train/train_frame.h"
#include "train/train_loop.h"
#include "train/trainer.h"

namespace haha {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr const char* kUsage = R"(usage: train_bench [options]

Builds the synthetic subject in memory (as `haha synth` writes it), trains the three HAHA
stages on it (as `haha train` on that dataset), prints the time per stage and evaluates
the avatars on the test frames (as `haha eval`, CPU, no test-time pose optimisation).

options:
  --subject N        1 (skirt, ponytail) or 2 (long hair, coat)            [1]
  --size PX          rendered frame side; training resamples to the preset's
                     resolution as `haha train` does                       [544]
  --frames N         training frames (the turn)                            [40]
  --test-frames N    test frames (novel poses)                             [10]
  --seed S           subject, motion, fit noise and body seed              [0]
  --fit-noise S      sigma of the fits' noise, pose (rad) and transl (m)   [0]
  --fit-noise-pose R     its pose part alone (rad)          [--fit-noise]
  --fit-noise-transl M   its transl part alone (m)          [--fit-noise]
  --preset NAME      tiny or paper                                         [tiny]
  --set KEY=VALUE    config override, repeatable (as `haha train KEY=VALUE`)
  --device NAME      cpu, cuda or auto                                     [cpu]
  --threads N        CPU threads                                           [all cores]
  --no-eval          skip the evaluation
  --json FILE        also write the numbers as JSON
  --help             this text
)";

struct Options {
  Options() { synth.size = 544; }  // the paper's resolution (haha synth's default is 128)
  SynthOptions synth;
  double fit_noise = 0, fit_noise_pose = -1, fit_noise_transl = -1;  // -1: as fit_noise
  std::string preset = "tiny";
  std::vector<std::string> sets;
  std::string device = "cpu";
  int threads = 0;
  bool eval = true;
  std::string json;
  bool help = false;
};

template <class T>
T parse_number(const std::string& opt, const std::string& text) {
  T v{};
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, v);
  if (ec != std::errc() || p != end || text.empty()) fail(opt, "'" + text + "' is not a valid number");
  return v;
}

Options parse_args(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i], value;
    bool has_value = false;
    if (const size_t eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg.resize(eq);
      has_value = true;
    }
    auto next = [&]() -> const std::string& {
      if (!has_value) {
        if (i + 1 >= argc) fail(arg, "needs a value");
        value = argv[++i];
        has_value = true;
      }
      return value;
    };
    auto flag = [&] {
      if (has_value) fail(arg, "takes no value");
    };
    if (arg == "--help" || arg == "-h") {
      flag();
      o.help = true;
    } else if (arg == "--subject") {
      o.synth.subject = parse_number<int>(arg, next());
    } else if (arg == "--size") {
      o.synth.size = parse_number<int>(arg, next());
    } else if (arg == "--frames") {
      o.synth.train_frames = parse_number<int>(arg, next());
    } else if (arg == "--test-frames") {
      o.synth.test_frames = parse_number<int>(arg, next());
    } else if (arg == "--seed") {
      o.synth.seed = parse_number<uint64_t>(arg, next());
    } else if (arg == "--fit-noise") {
      o.fit_noise = parse_number<double>(arg, next());
    } else if (arg == "--fit-noise-pose") {
      o.fit_noise_pose = parse_number<double>(arg, next());
      if (!(o.fit_noise_pose >= 0 && o.fit_noise_pose <= 1)) fail(arg, "must be in [0, 1]");
    } else if (arg == "--fit-noise-transl") {
      o.fit_noise_transl = parse_number<double>(arg, next());
      if (!(o.fit_noise_transl >= 0 && o.fit_noise_transl <= 1)) fail(arg, "must be in [0, 1]");
    } else if (arg == "--preset") {
      o.preset = next();
    } else if (arg == "--set") {
      o.sets.push_back(next());
    } else if (arg == "--device") {
      o.device = next();
    } else if (arg == "--threads") {
      o.threads = parse_number<int>(arg, next());
      if (o.threads < 1) fail(arg, "must be at least 1");
    } else if (arg == "--no-eval") {
      flag();
      o.eval = false;
    } else if (arg == "--json") {
      o.json = next();
      if (o.json.empty()) fail(arg, "empty file name");
    } else {
      fail(arg, "unknown option (see --help)");
    }
  }
  // As `haha synth --fit-noise`: one sigma for both the pose and transl unless given apart.
  if (!(o.fit_noise >= 0 && o.fit_noise <= 1)) fail("--fit-noise", "must be in [0, 1]");
  o.synth.fit_noise.pose = o.fit_noise_pose >= 0 ? o.fit_noise_pose : o.fit_noise;
  o.synth.fit_noise.transl = o.fit_noise_transl >= 0 ? o.fit_noise_transl : o.fit_noise;
  return o;
}

// ---- JSON output (no JSON library in this build) -----------------------------------------

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\u%04x", c);
      out += b;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string json_number(double v) {  // JSON has no inf / nan
  if (!std::isfinite(v)) return "null";
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, v);  // shortest text that reads back exactly
  return std::string(b, r.ptr);
}

struct StageRow {
  const char* name;
  int steps = 0;
  double seconds = 0;
  int gaussians = 0;  // at the end of the stage
};

struct EvalRow {
  std::string name;
  double psnr = 0, ssim = 0, render_ms = 0;
  int gaussians = 0;
};

std::string ms_per_step(const StageRow& s) {
  if (s.steps <= 0) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", 1000.0 * s.seconds / s.steps);
  return b;
}

// The config of --preset and --set, with every option checked before the work starts.
TrainConfig checked_config(const Options& o) {
  TrainConfig cfg = make_preset(o.preset);
  apply_overrides(cfg, o.sets, "--set");
  validate_config(cfg);
  validate_synth_options(o.synth);
  if (o.eval && o.synth.test_frames == 0) fail("--test-frames", "0 leaves nothing to evaluate (add --no-eval)");
  if (!o.json.empty()) {  // before the work, not after it
    const std::filesystem::path parent = std::filesystem::absolute(o.json).parent_path();
    if (!std::filesystem::is_directory(parent)) fail(o.json, "directory " + parent.string() + " does not exist");
  }
  return cfg;
}

// Everything the run measured, for the tables and the JSON.
struct BenchNumbers {
  int width = 0, height = 0;  // the training resolution
  double gen_seconds = 0, prefit_seconds = 0, train_seconds = 0, eval_seconds = 0;
  std::array<StageRow, 3> stages;
  int64_t skipped_steps = 0;
  size_t test_frames = 0;
  std::vector<EvalRow> eval;
};

struct SubjectFrames {
  SynthScene scene;
  std::vector<TrainFrame> train, test;
};

// The subject's frames, as `haha synth` (procedural body at full resolution) and
// `haha train` / `haha eval` (frames resampled to the config's resolution) see them.
SubjectFrames render_subject_frames(const BodyModel& body, const Options& o, const TrainConfig& cfg) {
  SubjectFrames f;
  f.scene = make_synth_scene(body, o.synth);
  const SynthScene& scene = f.scene;
  render_synth_frames(body, scene, [&](int i, const Image& rgb, const Image& mask) {
    const bool is_train = i < o.synth.train_frames;
    if (!is_train && !o.eval) return;
    Image rgb8 = rgb, mask8 = mask;
    round_to_8bit(rgb8);  // the dataset's PNGs
    round_to_8bit(mask8);
    const std::string name = is_train ? "train frame " + std::to_string(i)
                                      : "test frame " + std::to_string(i - o.synth.train_frames);
    (is_train ? f.train : f.test)
        .push_back(make_train_frame(name, scene.camera, scene.fits[size_t(i)], rgb8, mask8, cfg.resolution));
  });
  return f;
}

// The three stages as `haha train` runs them, a progress line every twentieth of the run
// and every 10 s; the time and final Gaussian count of each stage.
std::array<StageRow, 3> train_stages(Trainer& trainer, const TrainConfig& cfg) {
  std::array<StageRow, 3> stages = {
      StageRow{"1 Gaussians", cfg.s1.steps}, StageRow{"2 texture", cfg.s2.steps}, StageRow{"3 filtering", cfg.s3.steps}};
  const int64_t total = cfg.total_steps();
  auto last_line = Clock::now();
  TrainLoopHooks hooks;
  hooks.print_line = [&](const StepReport&, bool stage_end) {
    const int64_t done = trainer.completed_steps();
    const bool twentieth = (done * 20) / total != ((done - 1) * 20) / total;
    if (!(twentieth || stage_end || seconds_since(last_line) >= 10)) return false;
    last_line = Clock::now();
    return true;
  };
  hooks.log = [](const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  hooks.after_step = [&](const StepReport& r, bool stage_end) {
    if (stage_end) stages[r.stage - 1].gaussians = r.gaussians;
  };
  run_train_loop(trainer, hooks);
  // A stage of 0 steps ends without a step of its own: its count is the previous stage's.
  for (int s = 0; s < 3; ++s) {
    stages[s].seconds = trainer.stage_seconds()[size_t(s)];
    if (stages[s].steps == 0) stages[s].gaussians = s > 0 ? stages[s - 1].gaussians : trainer.stage1_avatar().gaussians.size();
  }
  stages[2].gaussians = trainer.num_gaussians();
  return stages;
}

void print_stage_table(const BenchNumbers& b, const TrainConfig& cfg) {
  const int64_t total = cfg.total_steps();
  std::printf("\n%-14s %8s %10s %10s %10s\n", "stage", "steps", "seconds", "ms/step", "Gaussians");
  for (const StageRow& s : b.stages)
    std::printf("%-14s %8d %10.2f %10s %10d\n", s.name, s.steps, s.seconds, ms_per_step(s).c_str(), s.gaussians);
  std::printf("%-14s %8lld %10.2f\n", "total", static_cast<long long>(total), b.train_seconds);
  if (cfg.s0.steps > 0) std::printf("pose pre-fit: %.2f s (not in the total)\n", b.prefit_seconds);
  std::printf("subject generation: %.2f s (not in the total)\n", b.gen_seconds);
  if (b.skipped_steps > 0) std::printf("skipped (non-finite) steps: %lld\n", static_cast<long long>(b.skipped_steps));
}

// Mesh only, full Gaussians and HAHA on the test frames as `haha eval` scores them, each
// row printed as it is done.
std::vector<EvalRow> evaluate_avatars(const Trainer& trainer, const TrainConfig& cfg, const std::vector<TrainFrame>& test) {
  std::vector<EvalRow> eval;
  const Avatar filtered = trainer.avatar(), full = trainer.stage1_avatar();
  EvalOptions opt;  // `haha eval`'s defaults on a black background, without its pose optimisation
  opt.tto_steps = 0;
  opt.premultiplied = resolve_premultiplied(cfg.premultiplied, true);
  std::vector<EvalVariant> variants = paper_variants(filtered, full);
  variants.erase(variants.begin() + 2);  // the naive merge: not needed for timing runs
  std::printf("\nevaluation: %zu test frames (novel poses), CPU, no test-time pose optimisation\n", test.size());
  std::printf("%-14s %8s %8s %10s %10s\n", "variant", "PSNR", "SSIM", "Gaussians", "ms/frame");
  for (const EvalVariant& v : variants) {
    const VariantEval e = evaluate_variant(v, test, opt);
    eval.push_back({v.name, e.psnr, e.ssim, e.render_ms, e.num_gaussians});
    std::printf("%-14s %8.2f %8.4f %10d %10.2f\n", v.name.c_str(), e.psnr, e.ssim, e.num_gaussians, e.render_ms);
    std::fflush(stdout);
  }
  return eval;
}

std::string bench_json(const Options& o, const TrainConfig& cfg, Device device, const std::string& gpu,
                       const BenchNumbers& b) {
  std::string j = "{\n";
  auto field = [&](const std::string& key, const std::string& value, bool last = false) {
    j += "  " + json_string(key) + ": " + value + (last ? "\n" : ",\n");
  };
  field("subject", std::to_string(o.synth.subject));
  field("size", std::to_string(o.synth.size));
  field("train_frames", std::to_string(o.synth.train_frames));
  field("test_frames", std::to_string(o.synth.test_frames));
  field("seed", std::to_string(o.synth.seed));
  field("fit_noise_pose", json_number(o.synth.fit_noise.pose));
  field("fit_noise_transl", json_number(o.synth.fit_noise.transl));
  field("preset", json_string(cfg.preset));
  std::string overrides = "[";
  for (size_t i = 0; i < o.sets.size(); ++i) overrides += (i ? ", " : "") + json_string(o.sets[i]);
  field("overrides", overrides + "]");
  field("device", json_string(device_name(device)));
  field("gpu", gpu.empty() ? "null" : json_string(gpu));
  field("threads", std::to_string(num_threads()));
  field("resolution", "[" + std::to_string(b.width) + ", " + std::to_string(b.height) + "]");
  field("generate_seconds", json_number(b.gen_seconds));
  field("prefit_seconds", json_number(b.prefit_seconds));
  std::string st = "[\n";
  for (int s = 0; s < 3; ++s) {
    const StageRow& r = b.stages[s];
    st += "    {\"stage\": " + std::to_string(s + 1) + ", \"steps\": " + std::to_string(r.steps) +
          ", \"seconds\": " + json_number(r.seconds) +
          ", \"ms_per_step\": " + (r.steps > 0 ? json_number(1000.0 * r.seconds / r.steps) : "null") +
          ", \"gaussians\": " + std::to_string(r.gaussians) + (s < 2 ? "},\n" : "}\n");
  }
  field("stages", st + "  ]");
  field("train_seconds", json_number(b.train_seconds));
  field("skipped_steps", std::to_string(b.skipped_steps));
  if (o.eval) {
    const std::vector<EvalRow>& eval = b.eval;
    std::string ev = "{\"frames\": " + std::to_string(b.test_frames) + ", \"tto_steps\": 0, \"seconds\": " +
                     json_number(b.eval_seconds) + ", \"variants\": [\n";
    for (size_t i = 0; i < eval.size(); ++i)
      ev += "    {\"name\": " + json_string(eval[i].name) + ", \"psnr\": " + json_number(eval[i].psnr) +
            ", \"ssim\": " + json_number(eval[i].ssim) + ", \"gaussians\": " + std::to_string(eval[i].gaussians) +
            ", \"render_ms\": " + json_number(eval[i].render_ms) + (i + 1 < eval.size() ? "},\n" : "}\n");
    field("eval", ev + "  ]}", true);
  } else {
    field("eval", "null", true);
  }
  return j + "}\n";
}

int run(const Options& o) {
  set_num_threads(o.threads);
  const TrainConfig cfg = checked_config(o);
  const Device device = parse_device(o.device);  // a missing GPU fails here, before any work
  const std::string gpu = device == Device::cuda ? gpu_description() : "";
  std::string sets;
  for (const std::string& kv : o.sets) sets += " " + kv;
  std::printf("train_bench: subject %d, %d px, %d train + %d test frames, preset %s%s, device %s%s%s, %d threads\n",
              o.synth.subject, o.synth.size, o.synth.train_frames, o.synth.test_frames, cfg.preset.c_str(),
              sets.c_str(), device_name(device), gpu.empty() ? "" : ": ", gpu.c_str(), num_threads());
  std::fflush(stdout);

  BenchNumbers b;
  const auto t_gen = Clock::now();
  const BodyModel body = make_procedural_body({BodyResolution::full, o.synth.seed});
  SubjectFrames frames = render_subject_frames(body, o, cfg);
  b.gen_seconds = seconds_since(t_gen);
  b.width = frames.train[0].camera.width;
  b.height = frames.train[0].camera.height;
  std::printf("subject: %d body vertices, %zu garment meshes, %d frames rendered at %d px in %.1f s; training at %dx%d\n",
              body.num_verts, frames.scene.subject.meshes.size(), int(frames.scene.truth.size()), o.synth.size,
              b.gen_seconds, b.width, b.height);

  TrainInput input;
  input.body = &body;
  input.frames = std::move(frames.train);
  input.premultiplied = resolve_premultiplied(cfg.premultiplied, true);  // `haha synth` writes "premultiplied": true
  if (cfg.s0.steps > 0) {
    const auto t0 = Clock::now();
    fit_poses_to_masks(body, input.frames, cfg.s0);
    b.prefit_seconds = seconds_since(t0);
    std::printf("pose pre-fit to the masks: %d steps per frame, %.1f s\n", cfg.s0.steps, b.prefit_seconds);
  }
  Trainer trainer(cfg, std::move(input), device);
  b.stages = train_stages(trainer, cfg);
  for (const StageRow& s : b.stages) b.train_seconds += s.seconds;
  b.skipped_steps = trainer.skipped_steps();
  print_stage_table(b, cfg);

  if (o.eval) {
    const auto t0 = Clock::now();
    b.test_frames = frames.test.size();
    b.eval = evaluate_avatars(trainer, cfg, frames.test);
    b.eval_seconds = seconds_since(t0);
    std::printf("evaluation: %.2f s\n", b.eval_seconds);
  }

  if (!o.json.empty()) {
    write_text_file(o.json, bench_json(o, cfg, device, gpu, b));
    std::printf("wrote %s\n", o.json.c_str());
  }
  return 0;
}

}  // namespace
}  // namespace haha

int main(int argc, char** argv) {
  try {
    const haha::Options o = haha::parse_args(argc, argv);
    if (o.help) {
      std::fputs(haha::kUsage, stdout);
      return 0;
    }
    return haha::run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "train_bench: error: %s\n", e.what());
    return 1;
  }
}
