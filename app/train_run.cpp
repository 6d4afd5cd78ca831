#include "app/train_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "app/lpips_weights.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "core/parallel.h"
#include "data/dataset.h"
#include "format/avatar_npz.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"
#include "render/texture_charts.h"
#include "train/device.h"
#include "train/photo_fit.h"
#include "train/garment_fit.h"
#include "train/surface_fit.h"
#include "train/texture_evidence.h"
#include "train/progress.h"
#include "train/silhouette_fit.h"
#include "train/train_frame.h"
#include "train/train_loop.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

// The pose pre-fit to the masks (train/silhouette_fit.h) with progress lines and a summary.
void prefit_poses(const BodyModel& body, std::vector<TrainFrame>& frames, const Stage0Config& s0,
                  const std::function<void(const std::string&)>& log) {
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const SilhouetteFitReport fit = fit_poses_to_masks(body, frames, s0, [&](int done, int total) {
    if (done % 10 != 0 || done == total) return;
    log("[pose pre-fit] " + std::to_string(done) + "/" + std::to_string(total) + " frames | ETA " +
        format_duration(seconds() / done * (total - done)));
  });
  const int n = int(frames.size());
  double a = 0, b = 0;
  for (size_t i = 0; i < fit.loss_start.size(); ++i) a += fit.loss_start[i], b += fit.loss_end[i];
  char line[160];
  std::snprintf(line, sizeof line, "pose pre-fit to the masks: %d frames x %d steps, silhouette loss %.4g -> %.4g (%.1f s)",
                n, s0.steps, a / n, b / n, seconds());
  log(line);
}

// The photometric pose fit against a textured mesh (train/photo_fit.h) with progress lines.
// At s0.photo.resolution it works on its own copy of the training frames, read again from
// the dataset, and hands the poses back.
void photo_fit_poses(const BodyModel& body, Dataset& ds, std::vector<TrainFrame>& train_frames, bool premultiplied,
                     const TrainConfig& cfg, const std::function<void(const std::string&)>& log) {
  const int train_side = std::max(train_frames[0].camera.width, train_frames[0].camera.height);
  const int side = cfg.s0.photo.resolution > 0 ? std::min(cfg.s0.photo.resolution, std::max(ds.width, ds.height)) : train_side;
  std::vector<TrainFrame> own;
  if (side != train_side) {
    own = dataset_frames(ds, Split::train, side);
    for (DatasetFrame& f : ds.frames) f.image = Image(), f.mask = Image();  // the copies are in `own`
    for (size_t i = 0; i < own.size(); ++i) own[i].params = train_frames[i].params;
  }
  std::vector<TrainFrame>& frames = own.empty() ? train_frames : own;
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const PhotoFitReport fit =
      fit_poses_to_images(body, frames, premultiplied, cfg.s0, cfg.seed, [&](int done, int total, double loss) {
        check_interrupted();  // Ctrl-C: nothing of the run is written yet
        char line[160];
        std::snprintf(line, sizeof line, "[photometric pose fit] step %d/%d | loss %.4g | ETA %s", done, total, loss,
                      format_duration(seconds() / done * (total - done)).c_str());
        log(line);
      });
  for (size_t i = 0; i < own.size(); ++i) train_frames[i].params = own[i].params;
  char line[200];
  std::snprintf(line, sizeof line,
                "photometric pose fit against a textured mesh: %d steps over %zu frames at %dx%d, image loss %.4g -> %.4g "
                "(%.1f s)",
                cfg.s0.photo.steps, frames.size(), frames[0].camera.width, frames[0].camera.height, fit.loss_start,
                fit.loss_end, seconds());
  log(line);
}

// The clothed surface (train/surface_fit.h) with progress lines: the body the trainer gets,
// its rest displacement also written to the run directory (a resumed run reads it back).
// With a garment on the body and the surface fit off, the garment alone is fitted.
BodyModel fit_clothed_surface(const BodyModel& body, const std::vector<TrainFrame>& frames, bool premultiplied,
                              const TrainConfig& cfg, const RunDir& run, const std::function<void(const std::string&)>& log,
                              ojson& summary) {
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  Stage0Config::Surface opt = cfg.s0.surface;
  opt.garment_max_out = cfg.s0.garment.max_out;
  opt.garment_lr = cfg.s0.garment.lr;
  opt.garment_lr_final = cfg.s0.garment.lr_final;
  opt.garment_w_laplacian = cfg.s0.garment.w_laplacian;
  opt.garment_only = opt.steps <= 0;
  if (opt.garment_only) opt.steps = cfg.s0.garment.steps;
  const char* what = opt.garment_only ? "garment" : "clothed surface";
  const SurfaceFitReport fit =
      fit_rest_surface(body, frames, premultiplied, opt, cfg.seed, [&](int done, int total, double loss) {
        check_interrupted();  // Ctrl-C: nothing of the run is written yet
        char line[160];
        std::snprintf(line, sizeof line, "[%s] step %d/%d | loss %.4g | ETA %s", what, done, total, loss,
                      format_duration(seconds() / done * (total - done)).c_str());
        log(line);
      });
  char line[240];
  std::snprintf(line, sizeof line,
                "%s: %d steps at %d px, data loss %.4g -> %.4g; displacement mean %.1f mm, 95%% under %.1f mm, "
                "largest %.1f mm, %d vertices held by another part to under half their outward bound (%.1f s)",
                what, opt.steps, fit.side, fit.loss_start, fit.loss_end, fit.mean_mm, fit.p95_mm, fit.max_mm, fit.part_held,
                seconds());
  log(line);
  summary["clothed_surface"] = {{"steps", opt.steps}, {"garment_only", opt.garment_only}, {"side", fit.side},
                                {"loss", {fit.loss_start, fit.loss_end}}, {"mean_mm", fit.mean_mm}, {"p95_mm", fit.p95_mm},
                                {"max_mm", fit.max_mm}, {"part_held", fit.part_held},
                                {"seconds", seconds()}};
  ensure_directory(run.dir);
  write_npy(run.rest_offsets(), NpyArray::from(fit.offsets, {int64_t(body.num_verts), 3}));
  BodyModel out = body;
  out.rest_offsets = fit.offsets;
  return out;
}

// The garment decision (train/garment_fit.h): the body with the garment appended (written to
// the run directory for --resume) or the body as it was; one log line, summary["garment"].
BodyModel with_garment(const BodyModel& model, const std::vector<TrainFrame>& frames, const TrainConfig& cfg,
                       const RunDir& run, const std::function<void(const std::string&)>& log, ojson& summary) {
  const GarmentDecision d = decide_garment(model, frames, cfg.s0.garment);
  log(d.why);
  ojson levels = ojson::array();
  for (size_t k = 0; k < d.t.size(); ++k)
    levels.push_back({{"t", d.t[k]}, {"pixels", d.pixels[k]}, {"fill", std::isnan(d.fill[k]) ? ojson() : ojson(d.fill[k])}});
  summary["garment"] = {{"mode", d.mode}, {"made", d.made}, {"why", d.why}, {"levels", levels}};
  if (!d.made) return model;
  summary["garment"]["y_top"] = d.y_top;
  summary["garment"]["y_hem"] = d.y_hem;
  summary["garment"]["vertices"] = d.garment.num_verts();
  summary["garment"]["faces"] = d.garment.num_faces();
  ensure_directory(run.dir);
  save_garment_npz(d.garment, run.garment());
  return append_garment(model, d.garment);
}

// A resumed run's body: the model with the garment and the rest displacement its first run
// made.
BodyModel resumed_body(const BodyModel& model, const TrainConfig& cfg, const RunDir& run) {
  BodyModel out = fs::exists(run.garment()) ? append_garment(model, load_garment_npz(run.garment())) : model;
  if (cfg.s0.surface.steps <= 0 && (!out.has_garment() || cfg.s0.garment.steps <= 0)) return out;  // nothing fitted
  const std::string path = run.rest_offsets();
  if (!fs::exists(path)) fail(path, "--resume: the run fitted a clothed surface but its displacement is missing");
  out.rest_offsets = read_npy(path).as_float();
  if (out.rest_offsets.size() != size_t(out.num_verts) * 3)
    fail(path, "rest displacement of " + std::to_string(out.rest_offsets.size() / 3) + " vertices, the body has " +
                   std::to_string(out.num_verts));
  for (float x : out.rest_offsets)
    if (!std::isfinite(x)) fail(path, "non-finite rest displacement");
  return out;
}

// The body the trainer gets: the model with the garment (when one is made) and the clothed
// surface fitted now, or (resume) read back from the run.
BodyModel training_body(const BodyModel& model, const TrainInput& input, const TrainConfig& cfg, const RunDir& run,
                        bool resume, const std::function<void(const std::string&)>& log, ojson& summary) {
  if (resume) return resumed_body(model, cfg, run);
  const BodyModel body = with_garment(model, input.frames, cfg, run, log, summary);
  if (cfg.s0.surface.steps <= 0 && (!body.has_garment() || cfg.s0.garment.steps <= 0)) return body;
  return fit_clothed_surface(body, input.frames, input.premultiplied, cfg, run, log, summary);
}

// The filtering's validated stop for train_summary.json, and its log line.
ojson filter_stop_summary(const Trainer& trainer, int gaussians_stage1, const std::function<void(const std::string&)>& log) {
  const TrainConfig& cfg = trainer.config();
  const std::vector<FilterStopPoint> pts = trainer.filter_points();
  const int c = trainer.filter_choice();
  ojson j;
  j["validation_frames"] = trainer.validation_params().size();
  j["stop_db"] = cfg.s3.stop_db;
  j["max_kept"] = cfg.s3.max_kept;
  ojson rows = ojson::array();
  for (const FilterStopPoint& p : pts) rows.push_back({{"step", p.step}, {"gaussians", p.gaussians}, {"psnr", p.psnr}});
  j["points"] = rows;
  j["chosen"] = c;
  double best = pts.empty() ? 0 : pts[0].psnr;
  for (const FilterStopPoint& p : pts) best = std::max(best, p.psnr);
  const FilterStopPoint& p = pts[size_t(c)];
  char b[256];
  std::snprintf(b, sizeof b,
                "filtering stopped at step %d of %d: %d Gaussians (%.1f%% of stage 1), validation PSNR %.2f dB "
                "(best %.2f over %zu points, %zu views)",
                p.step, cfg.s3.steps, p.gaussians, 100.0 * p.gaussians / std::max(1, gaussians_stage1), p.psnr, best,
                pts.size(), trainer.validation_params().size());
  log(b);
  return j;
}

// The finished run's files: both avatars, the refined fits of every training frame (the
// held-out validation views' in their places), train_summary.json; the closing log line.
void write_run_outputs(const Trainer& trainer, const RunDir& run, int W, int H, const std::vector<size_t>& held,
                       const ojson& surface_summary, const std::function<void(const std::string&)>& log,
                       TrainRunResult& res) {
  const TrainConfig& cfg = trainer.config();
  const Avatar s1 = trainer.stage1_avatar();
  res.gaussians_stage1 = s1.gaussians.size();
  save_avatar_npz(trainer.avatar(), run.avatar());
  save_avatar_npz(s1, run.stage1_avatar());
  std::vector<SmplxParams> fits = trainer.refined_params();
  const std::vector<SmplxParams> vfits = trainer.validation_params();
  for (size_t k = 0; k < held.size() && k < vfits.size(); ++k)
    fits.insert(fits.begin() + std::ptrdiff_t(held[k]), vfits[k]);
  write_smplx_params(run.refined_fits(), fits);
  const std::vector<float> evidence = trainer.texture_evidence();
  const Avatar& final_avatar = s1;  // both avatars carry the final texture
  ojson s;
  if (!evidence.empty() && evidence.size() * 3 == final_avatar.texture.rgb.size()) {
    const int S = final_avatar.texture.width;
    write_npy(run.texture_evidence(), NpyArray::from(evidence, {int64_t(S), int64_t(S)}));
    const TextureCharts charts = texture_charts(final_avatar.body, S, S);
    s["texture"] = {{"evidence_full", cfg.s2.evidence_full},
                    {"low_evidence_share", evidence_share_below(evidence, charts, cfg.s2.evidence_full)},
                    {"filled", cfg.s2.fill}};
  }
  s["stage_seconds"] = {res.stage_seconds[0], res.stage_seconds[1], res.stage_seconds[2]};
  s["train_seconds"] = res.stage_seconds[0] + res.stage_seconds[1] + res.stage_seconds[2];
  s["gaussians_stage1"] = res.gaussians_stage1;
  s["gaussians_final"] = res.gaussians;
  s["skipped_steps"] = trainer.skipped_steps();
  s["steps"] = {cfg.s1.steps, cfg.s2.steps, cfg.s3.steps};
  s["frames"] = trainer.refined_params().size();
  s["resolution"] = {W, H};
  s["lpips"] = trainer.lpips_active();
  s["threads"] = num_threads();
  s["device"] = device_name(trainer.device());
  for (const auto& [k, v] : surface_summary.items()) s[k] = v;  // clothed_surface, garment
  if (trainer.filter_choice() >= 0) s["filter_stop"] = filter_stop_summary(trainer, res.gaussians_stage1, log);
  write_text_file(run.train_summary(), s.dump(2) + "\n");
  char buf[256];
  std::snprintf(buf, sizeof buf, "done: %d Gaussians after stage 1, %d after filtering; stages %.1f s / %.1f s / %.1f s",
                res.gaussians_stage1, res.gaussians, res.stage_seconds[0], res.stage_seconds[1], res.stage_seconds[2]);
  log(buf);
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
  const Device device = parse_device(opt.device);  // before any reading: a missing GPU fails at once
  const RunDir run(opt.run_dir);
  const std::string config_path = run.config();
  const std::string ck_path = run.checkpoint();

  RunInfo info;
  if (opt.resume) {
    if (!fs::exists(config_path)) fail(config_path, "--resume: no run to resume here (config.json missing)");
    if (!opt.overrides.empty())
      fail("--resume", "the run's saved config is used; key=value overrides are not allowed when resuming");
    info = read_trained_run_info(run, "--resume");
    if (!opt.data_dir.empty() && fs::weakly_canonical(opt.data_dir) != fs::weakly_canonical(info.data_path))
      fail("--data", "differs from the run's dataset " + info.data_path);
  } else {
    if (opt.data_dir.empty()) fail("--data", "no dataset directory given");
    if (!fs::is_directory(opt.data_dir)) fail(opt.data_dir, "dataset directory not found");
    // Bad keys and values fail here, before any reading; the settings for estimated fits
    // come once the dataset says what its fits are (below).
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
  const BodyModel model = load_body_model(info.model_path);
  Dataset ds = read_dataset(info.data_path, LoadPixels::all);
  if (!opt.resume) {  // a resumed run keeps its saved config
    std::string picked;
    info.config = make_run_config(opt.preset, opt.overrides, fits_name(ds.fits), &picked);
    log(picked);
  }
  LpipsWeights lw;
  if (!info.lpips_weights_path.empty()) lw = read_lpips_weights(info.lpips_weights_path);
  TrainInput input;
  input.premultiplied = dataset_premultiplied(ds, cfg.premultiplied);
  input.frames = dataset_frames(ds, Split::train, dataset_train_resolution(ds, cfg));
  if (input.frames.empty()) fail(info.data_path, "the dataset has no training frames");
  input.lpips = info.lpips_weights_path.empty() ? nullptr : &lw;
  for (DatasetFrame& f : ds.frames) f.image = Image(), f.mask = Image();  // the copies are in input.frames
  const int W = input.frames[0].camera.width, H = input.frames[0].camera.height;
  if (!opt.resume && fs::exists(ck_path))  // before the fits spend minutes and the surface fit writes here
    fail(ck_path, "a run already exists here; use --resume to continue it or choose another --out");
  if (cfg.s0.steps > 0 && !opt.resume)  // a resumed run has its refined poses in the checkpoint
    prefit_poses(model, input.frames, cfg.s0, log);
  if (cfg.s0.photo.steps > 0 && !opt.resume) photo_fit_poses(model, ds, input.frames, input.premultiplied, cfg, log);
  std::vector<size_t> held;  // indices (among the training frames) of the validation views
  if (cfg.s3.validation_every > 0) {
    const size_t total = input.frames.size();
    input.validation = hold_out_frames(input.frames, cfg.s3.validation_every, &held);
    log("validation: " + std::to_string(held.size()) + " of " + std::to_string(total) +
        " training frames held out of training, to choose where the filtering stops");
  }
  const int num_frames = int(input.frames.size());
  ojson surface_summary = ojson::object();  // the garment decision and the clothed-surface fit of this call
  const BodyModel body = training_body(model, input, cfg, run, opt.resume, log, surface_summary);
  input.body = &body;
  Trainer trainer(cfg, std::move(input), device);
  if (device == Device::cuda) log("device: cuda, " + gpu_description());

  if (opt.resume) {
    if (!fs::exists(ck_path)) fail(ck_path, "--resume: no checkpoint to resume from");
    trainer.load(read_checkpoint(ck_path), ck_path);
    log("resumed " + opt.run_dir + " at stage " + std::to_string(trainer.stage()) + " step " +
        std::to_string(trainer.step_in_stage()));
  } else {
    ensure_directory(opt.run_dir);
    write_run_info(run, info);
    const char* lp = trainer.lpips_active()           ? ", LPIPS-VGG loss on"
                     : info.lpips_weights_path.empty() ? ", LPIPS off (no --lpips-weights)"
                                                       : ", LPIPS off (no VGG part in the weights, or images too small)";
    log("training " + std::to_string(num_frames) + " frames at " + std::to_string(W) + "x" + std::to_string(H) +
        ", preset " + cfg.preset + (cfg.s1.levels.empty() && cfg.s2.levels.empty() && cfg.s3.levels.empty()
                                  ? ""
                                  : " (coarse to fine, levels per stage '" + cfg.s1.levels + "' / '" + cfg.s2.levels +
                                        "' / '" + cfg.s3.levels + "')") +
        ", " + std::to_string(trainer.num_gaussians()) + " Gaussians at start" + lp);
  }

  TrainRunResult res;
  TrainLoopHooks hooks;
  hooks.stop = [&](int64_t steps_run) {
    if (opt.stop_after >= 0 && steps_run >= opt.stop_after) return true;
    if (interrupted()) {  // SIGTERM / SIGINT where the caller installed core/interrupt.h's handler
      write_checkpoint(ck_path, trainer.save());
      log("interrupted at stage " + std::to_string(trainer.stage()) + " step " + std::to_string(trainer.step_in_stage()) +
          " (checkpoint written; continue with --resume)");
      throw Error("interrupted");
    }
    return false;
  };
  hooks.print_line = [&](const StepReport& r, bool stage_end) {
    return r.step % cfg.log_every == 0 || stage_end || !r.event.empty() || r.skipped;
  };
  hooks.log = log;
  hooks.after_step = [&](const StepReport& r, bool stage_end) {
    if (stage_end) {
      write_checkpoint(run.stage_checkpoint(r.stage), trainer.save());
      write_checkpoint(ck_path, trainer.save());
    } else if (cfg.checkpoint_every > 0 && r.step % cfg.checkpoint_every == 0) {
      write_checkpoint(ck_path, trainer.save());
    }
  };
  res.steps_run = run_train_loop(trainer, hooks);
  res.finished = trainer.done();
  res.gaussians = trainer.num_gaussians();
  res.stage_seconds = trainer.stage_seconds();
  if (!res.finished) {
    write_checkpoint(ck_path, trainer.save());
    log("stopped at stage " + std::to_string(trainer.stage()) + " step " + std::to_string(trainer.step_in_stage()) +
        " (checkpoint written; continue with --resume)");
    return res;
  }
  write_run_outputs(trainer, run, W, H, held, surface_summary, log, res);
  return res;
}

}  // namespace haha
