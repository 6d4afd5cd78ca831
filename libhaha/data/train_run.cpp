#include "data/train_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/lpips_weights.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

constexpr const char* kRunFormat = "haha-run";
constexpr int kRunVersion = 1;

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void write_text(const std::string& path, const std::string& text) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.close();
    if (!f) fail(tmp, "write failed");
  });
}

std::string fmt_duration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  const int t = int(std::lround(s));
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%dh%02dm", t / 3600, (t / 60) % 60);
  else if (t >= 60)
    std::snprintf(buf, sizeof buf, "%dm%02ds", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%ds", t);
  return buf;
}

}  // namespace

// ---- config.json ------------------------------------------------------------------------

std::string run_info_to_json(const RunInfo& info) {
  ojson j;
  j["format"] = kRunFormat;
  j["version"] = kRunVersion;
  j["model"] = info.model_path;
  j["data"] = info.data_path;
  j["lpips_weights"] = info.lpips_weights_path.empty() ? ojson(nullptr) : ojson(info.lpips_weights_path);
  ojson c = ojson::object();
  TrainConfig copy = info.config;
  for (const ConfigEntry& e : config_entries(copy)) {
    switch (e.kind) {
      case ConfigEntry::Kind::Int: c[e.key] = *static_cast<int*>(e.ptr); break;
      case ConfigEntry::Kind::Uint64: c[e.key] = *static_cast<uint64_t*>(e.ptr); break;
      case ConfigEntry::Kind::Double: c[e.key] = *static_cast<double*>(e.ptr); break;
      case ConfigEntry::Kind::Bool: c[e.key] = *static_cast<bool*>(e.ptr); break;
      default: c[e.key] = config_value_string(e); break;
    }
  }
  j["config"] = c;
  return j.dump(2) + "\n";
}

void write_run_info(const std::string& path, const RunInfo& info) { write_text(path, run_info_to_json(info)); }

RunInfo read_run_info(const std::string& path) {
  ojson j;
  try {
    j = ojson::parse(read_text(path));
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object() || j.value("format", "") != kRunFormat) fail(path, "format: not a haha run config");
  if (j.value("version", 0) != kRunVersion) fail(path, "version: unsupported");
  RunInfo r;
  auto str = [&](const char* k) -> std::string {
    if (!j.contains(k) || !j[k].is_string()) fail(path, std::string(k) + ": expected a string");
    return j[k].get<std::string>();
  };
  r.model_path = str("model");
  r.data_path = str("data");
  if (j.contains("lpips_weights") && j["lpips_weights"].is_string()) r.lpips_weights_path = j["lpips_weights"];
  if (!j.contains("config") || !j["config"].is_object()) fail(path, "config: expected an object");
  r.config = TrainConfig{};
  for (const auto& [k, v] : j["config"].items()) {
    std::string text;
    if (v.is_string())
      text = v.get<std::string>();
    else if (v.is_boolean())
      text = v.get<bool>() ? "true" : "false";
    else if (v.is_number_unsigned())
      text = std::to_string(v.get<uint64_t>());
    else if (v.is_number_integer())
      text = std::to_string(v.get<int64_t>());
    else if (v.is_number_float()) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", v.get<double>());
      text = buf;
    } else {
      fail(path, "config: " + k + ": unsupported value");
    }
    set_config_value(r.config, k, text, path + ": config");
  }
  return r;
}

std::array<double, 3> read_train_seconds(const std::string& run_dir) {
  const std::string path = (fs::path(run_dir) / "train_summary.json").string();
  std::array<double, 3> out{0, 0, 0};
  if (!fs::exists(path)) return out;
  try {
    const ojson j = ojson::parse(read_text(path));
    const ojson& s = j.at("stage_seconds");
    for (size_t i = 0; i < 3 && i < s.size(); ++i) out[i] = s[i].get<double>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("stage_seconds: ") + e.what());
  }
  return out;
}

// ---- checkpoints ------------------------------------------------------------------------

void write_checkpoint(const std::string& path, const TrainCheckpoint& ck) {
  Npz z(path);
  for (const auto& [k, v] : ck.f32) z.set("f32/" + k, NpyArray::from(v, {int64_t(v.size())}));
  for (const auto& [k, v] : ck.i32) z.set("i32/" + k, NpyArray::from(v, {int64_t(v.size())}));
  for (const auto& [k, v] : ck.f64) z.set("f64/" + k, NpyArray::from(v, {int64_t(v.size())}));
  z.write(path);
}

TrainCheckpoint read_checkpoint(const std::string& path) {
  const Npz z = Npz::read(path);
  TrainCheckpoint ck;
  for (const std::string& k : z.keys()) {
    const NpyArray& a = z.get(k);
    if (k.rfind("f32/", 0) == 0) {
      if (a.dtype != DType::f32) fail(path, k + ": expected float32");
      ck.f32[k.substr(4)] = a.as_float();
    } else if (k.rfind("i32/", 0) == 0) {
      if (a.dtype != DType::i32) fail(path, k + ": expected int32");
      ck.i32[k.substr(4)] = a.as_int32();
    } else if (k.rfind("f64/", 0) == 0) {
      if (a.dtype != DType::f64) fail(path, k + ": expected float64");
      ck.f64[k.substr(4)] = a.as_double();
    }
  }
  if (ck.i32.count("meta.version") == 0) fail(path, "not a haha training checkpoint (meta.version missing)");
  return ck;
}

// ---- frames -------------------------------------------------------------------------------

bool dataset_premultiplied(const Dataset& ds, const std::string& setting) {
  if (setting == "true") return true;
  if (setting == "false") return false;
  return ds.source.rfind("haha synth", 0) == 0;
}

std::vector<TrainFrame> dataset_frames(Dataset& ds, Split split, int resolution) {
  std::vector<TrainFrame> out;
  for (int i : ds.indices(split)) {
    ds.load_frame(i);
    DatasetFrame& f = ds.frames[size_t(i)];
    TrainFrame t;
    t.name = f.image_path.empty() ? ds.path + ": frame " + std::to_string(i) : f.image_path;
    t.camera = f.camera;
    t.params = f.params;
    Image rgb = f.image, mask = f.mask;
    const int W = rgb.width, H = rgb.height;
    if (resolution > 0 && std::max(W, H) != resolution) {
      const double s = double(resolution) / double(std::max(W, H));
      const int nw = std::max(1, int(std::lround(W * s))), nh = std::max(1, int(std::lround(H * s)));
      rgb = resize_area(rgb, nw, nh);
      mask = resize_area(mask, nw, nh);
      const float sx = float(nw) / float(W), sy = float(nh) / float(H);
      t.camera.width = nw;
      t.camera.height = nh;
      t.camera.fx *= sx;
      t.camera.cx *= sx;
      t.camera.fy *= sy;
      t.camera.cy *= sy;
    }
    if (rgb.channels != 3) fail(t.name, "expected an RGB image");
    t.rgb = std::move(rgb.data);
    t.mask.resize(size_t(mask.width) * mask.height);
    for (size_t p = 0; p < t.mask.size(); ++p) t.mask[p] = std::clamp(mask.data[p * size_t(mask.channels)], 0.0f, 1.0f);
    out.push_back(std::move(t));
  }
  return out;
}

// ---- the driver -------------------------------------------------------------------------

namespace {

std::string progress_line(const StepReport& r, const Trainer& t, double rate, double eta) {
  char buf[512];
  const LossTerms& l = r.loss;
  std::string parts;
  auto add = [&](const char* name, double v) {
    if (v == 0) return;
    char b[48];
    std::snprintf(b, sizeof b, " %s %.4g", name, v);
    parts += b;
  };
  add("l2", l.l2);
  add("ssim", l.ssim);
  add("sobel", l.sobel);
  add("lpips", l.lpips);
  add("knn", l.knn);
  add("dice", l.dice);
  add("tv", l.tv);
  add("opac", l.opacity);
  std::snprintf(buf, sizeof buf, "[stage %d] %d/%d loss %.5f (%s) G %d | %.2f it/s | ETA %s%s", r.stage, r.step,
                r.steps, l.total, parts.empty() ? "" : parts.c_str() + 1, r.gaussians, rate, fmt_duration(eta).c_str(),
                r.skipped ? " | SKIPPED (non-finite)" : "");
  (void)t;
  return buf;
}

}  // namespace

TrainRunResult run_training(const TrainRunOptions& opt) {
  auto log = [&](const std::string& s) {
    if (opt.log)
      opt.log(s);
    else {
      std::printf("%s\n", s.c_str());
      std::fflush(stdout);
    }
  };
  if (opt.run_dir.empty()) fail("--out", "no run directory given");
  const fs::path run(opt.run_dir);
  const std::string config_path = (run / "config.json").string();
  const std::string ck_path = (run / "checkpoint.npz").string();

  RunInfo info;
  if (opt.resume) {
    if (!fs::exists(config_path)) fail(config_path, "--resume: no run to resume here (config.json missing)");
    if (!opt.overrides.empty())
      fail("--resume", "the run's saved config is used; key=value overrides are not allowed when resuming");
    info = read_run_info(config_path);
    if (!opt.data_dir.empty() && fs::weakly_canonical(opt.data_dir) != fs::weakly_canonical(info.data_path))
      fail("--data", "differs from the run's dataset " + info.data_path);
  } else {
    if (opt.data_dir.empty()) fail("--data", "no dataset directory given");
    if (!fs::is_directory(opt.data_dir)) fail(opt.data_dir, "dataset directory not found");
    info.config = make_preset(opt.preset);
    apply_overrides(info.config, opt.overrides, "override");
    validate_config(info.config);
    info.data_path = fs::absolute(opt.data_dir).lexically_normal().string();
    std::string model = opt.model_path;
    if (model.empty()) {
      model = (fs::path(opt.data_dir) / "body_model.npz").string();
      if (!fs::exists(model)) fail("--model", "no body model given and " + model + " does not exist");
    }
    info.model_path = fs::absolute(model).lexically_normal().string();
    if (!opt.lpips_weights.empty()) info.lpips_weights_path = fs::absolute(opt.lpips_weights).lexically_normal().string();
  }
  const TrainConfig& cfg = info.config;

  // Everything is read and validated before the first step.
  const BodyModel body = load_body_model(info.model_path);
  Dataset ds = read_dataset(info.data_path, LoadPixels::all);
  LpipsWeights lw;
  if (!info.lpips_weights_path.empty()) lw = read_lpips_weights(info.lpips_weights_path);
  TrainInput input;
  input.body = &body;
  input.premultiplied = dataset_premultiplied(ds, cfg.premultiplied);
  input.frames = dataset_frames(ds, Split::train, cfg.resolution);
  if (input.frames.empty()) fail(info.data_path, "the dataset has no training frames");
  input.lpips = info.lpips_weights_path.empty() ? nullptr : &lw;
  for (DatasetFrame& f : ds.frames) f.image = Image(), f.mask = Image();  // the copies are in input.frames
  const int num_frames = int(input.frames.size());
  const int W = input.frames[0].camera.width, H = input.frames[0].camera.height;
  Trainer trainer(cfg, std::move(input));

  if (opt.resume) {
    if (!fs::exists(ck_path)) fail(ck_path, "--resume: no checkpoint to resume from");
    trainer.load(read_checkpoint(ck_path), ck_path);
    log("resumed " + opt.run_dir + " at stage " + std::to_string(trainer.stage()) + " step " +
        std::to_string(trainer.step_in_stage()));
  } else {
    ensure_directory(opt.run_dir);
    if (fs::exists(ck_path))
      fail(ck_path, "a run already exists here; use --resume to continue it or choose another --out");
    write_run_info(config_path, info);
    const char* lp = trainer.lpips_active()           ? ", LPIPS-VGG loss on"
                     : info.lpips_weights_path.empty() ? ", LPIPS off (no --lpips-weights)"
                                                       : ", LPIPS off (no VGG part in the weights, or images too small)";
    log("training " + std::to_string(num_frames) + " frames at " + std::to_string(W) + "x" + std::to_string(H) +
        ", preset " + cfg.preset + ", " + std::to_string(trainer.num_gaussians()) + " Gaussians at start" + lp);
  }

  TrainRunResult res;
  auto t_stage = std::chrono::steady_clock::now();
  int stage_started_step = trainer.step_in_stage();
  int cur_stage = trainer.stage();
  while (!trainer.done()) {
    if (opt.stop_after >= 0 && res.steps_run >= opt.stop_after) break;
    const StepReport r = trainer.step();
    ++res.steps_run;
    const bool stage_end = trainer.stage() != r.stage;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_stage).count();
    const int done_in_stage = r.step - stage_started_step;
    const double rate = el > 0 ? done_in_stage / el : 0.0;
    // ETA: this stage at its measured rate, later stages at that rate scaled by their
    // typical relative step cost (stage 2 touches only the texture, stage 3 has no LBS or
    // position gradients); a rough guide, refined as each stage starts.
    const double cost[3] = {1.0, 0.15, 0.4};
    double eta = rate > 0 ? double(r.steps - r.step) / rate : NAN;
    for (int s = r.stage + 1; s <= 3 && rate > 0; ++s)
      eta += double(s == 2 ? cfg.s2.steps : cfg.s3.steps) * cost[s - 1] / cost[r.stage - 1] / rate;
    if (r.step % cfg.log_every == 0 || stage_end || !r.event.empty() || r.skipped) {
      log(progress_line(r, trainer, rate, eta));
      if (!r.event.empty()) log("  " + r.event);
    }
    if (stage_end) {
      write_checkpoint((run / ("checkpoint_stage" + std::to_string(r.stage) + ".npz")).string(), trainer.save());
      write_checkpoint(ck_path, trainer.save());
      t_stage = std::chrono::steady_clock::now();
      stage_started_step = 0;
      cur_stage = trainer.stage();
    } else if (cfg.checkpoint_every > 0 && r.step % cfg.checkpoint_every == 0) {
      write_checkpoint(ck_path, trainer.save());
    }
  }
  (void)cur_stage;
  res.finished = trainer.done();
  res.gaussians = trainer.num_gaussians();
  res.stage_seconds = trainer.stage_seconds();
  if (!res.finished) {
    write_checkpoint(ck_path, trainer.save());
    log("stopped at stage " + std::to_string(trainer.stage()) + " step " + std::to_string(trainer.step_in_stage()) +
        " (checkpoint written; continue with --resume)");
    return res;
  }
  // Outputs.
  const Avatar s1 = trainer.stage1_avatar();
  res.gaussians_stage1 = s1.gaussians.size();
  if (opt.save_avatar) {
    opt.save_avatar(trainer.avatar(), (run / "avatar.npz").string());
    opt.save_avatar(s1, (run / "avatar_stage1.npz").string());
  }
  write_smplx_params((run / "smplx_refined.npz").string(), trainer.refined_params());
  ojson s;
  s["stage_seconds"] = {res.stage_seconds[0], res.stage_seconds[1], res.stage_seconds[2]};
  s["train_seconds"] = res.stage_seconds[0] + res.stage_seconds[1] + res.stage_seconds[2];
  s["gaussians_stage1"] = res.gaussians_stage1;
  s["gaussians_final"] = res.gaussians;
  s["skipped_steps"] = trainer.skipped_steps();
  s["steps"] = {cfg.s1.steps, cfg.s2.steps, cfg.s3.steps};
  s["frames"] = num_frames;
  s["resolution"] = {W, H};
  s["lpips"] = trainer.lpips_active();
  s["threads"] = num_threads();
  write_text((run / "train_summary.json").string(), s.dump(2) + "\n");
  char buf[256];
  std::snprintf(buf, sizeof buf, "done: %d Gaussians after stage 1, %d after filtering; stages %.1f s / %.1f s / %.1f s",
                res.gaussians_stage1, res.gaussians, res.stage_seconds[0], res.stage_seconds[1], res.stage_seconds[2]);
  log(buf);
  return res;
}

}  // namespace haha
