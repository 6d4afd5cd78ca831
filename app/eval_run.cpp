#include "app/eval_run.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <string>
#include <vector>
#include <memory>

#include "app/lpips_weights.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "core/error.h"
#include "data/dataset.h"
#include "train/evaluate.h"

namespace haha {

namespace {

// Indices into paper_variants() of the --variants keys, in the table's order; all when none.
std::vector<size_t> chosen_rows(const std::vector<std::string>& keys) {
  const size_t n = std::size(kPaperVariantKeys);
  std::vector<bool> want(n, keys.empty());
  for (const std::string& k : keys) {
    const auto* it = std::find(std::begin(kPaperVariantKeys), std::end(kPaperVariantKeys), k);
    if (it == std::end(kPaperVariantKeys))
      fail("--variants", "unknown variant '" + k + "' (expected mesh, full, naive or haha)");
    want[size_t(it - std::begin(kPaperVariantKeys))] = true;
  }
  std::vector<size_t> rows;
  for (size_t i = 0; i < n; ++i)
    if (want[i]) rows.push_back(i);
  return rows;
}

}  // namespace

EvalReport run_eval(const EvalRunOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  chosen_rows(o.variants);  // a bad key fails before minutes of loading
  if (o.background != "black" && o.background != "white")
    fail("--background", "expected black or white, got '" + o.background + "'");
  const Split split = parse_split(o.split, "--split");
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!o.out_dir.empty() && fs::exists(o.out_dir, ec) && !fs::is_directory(o.out_dir, ec))
    fail(o.out_dir, "--out: exists and is not a folder");
  const RunDir run(o.run_dir);
  const RunInfo info = read_trained_run_info(run, "haha eval");
  const std::string data = o.data_dir.empty() ? info.data_path : o.data_dir;
  // Avatars: the final (filtered) one and the stage-1 (full Gaussian) one, same body.
  const Avatar filtered = load_run_avatar(run);
  const Avatar full = load_stage1_avatar(run, filtered.body);
  Dataset ds = read_dataset(data, LoadPixels::headers);
  std::vector<TrainFrame> frames = dataset_frames(ds, split, scoring_resolution(ds, info.config, o.resolution));
  if (frames.empty()) fail(data, "no " + o.split + " frames");
  if (o.frames > 0 && size_t(o.frames) < frames.size()) frames.resize(size_t(o.frames));

  EvalOptions opt;
  opt.tto_steps = o.tto_steps >= 0 ? o.tto_steps : info.config.eval_tto_steps;
  opt.tto_resolution = o.tto_resolution >= 0 ? o.tto_resolution : info.config.eval_tto_resolution;
  opt.lr_pose = info.config.eval_lr_pose;
  opt.lr_pose_fine = info.config.eval_lr_pose_fine;
  const float bgv = o.background == "white" ? 1.0f : 0.0f;
  for (float& c : opt.background) c = bgv;
  opt.premultiplied = dataset_premultiplied(ds, info.config.premultiplied);
  opt.keep_images = o.sheet_frames;
  if (o.antialias < -1 || o.antialias > 1) fail("--antialias", "expected -1 (the run's), 0 or 1");
  opt.antialias = o.antialias >= 0 ? o.antialias == 1 : info.config.eval_antialias;
  std::unique_ptr<LpipsNet<float>> alex;
  LpipsWeights lw;
  const std::string lp = o.lpips_weights.empty() ? info.lpips_weights_path : o.lpips_weights;
  if (!lp.empty()) {
    lw = read_lpips_weights(lp);
    if (lw.has_backbone(LpipsBackbone::Alex)) {
      alex = std::make_unique<LpipsNet<float>>(lw, LpipsBackbone::Alex);
      if (std::min(frames[0].camera.width, frames[0].camera.height) < alex->min_size()) alex.reset();
    }
  }
  opt.lpips = alex.get();

  EvalReport r;
  r.run_dir = o.run_dir;
  r.data_dir = data;
  r.split = o.split;
  r.background = o.background;
  r.preset = info.config.preset;
  r.tto_steps = opt.tto_steps;
  r.tto_resolution = opt.tto_resolution;
  r.width = frames[0].camera.width;
  r.height = frames[0].camera.height;
  r.train_resolution = dataset_train_resolution(ds, info.config);
  r.antialias = opt.antialias;
  r.lpips_available = alex != nullptr;
  // What the run changed from its preset: the user's keys, and for estimated fits
  // "fits=estimated" with the settings it brought (train/config.h make_run_config).
  // "fits=exact" is the preset's own settings: not a switch.
  const TrainConfig defaults = make_preset(info.config.preset);
  for (const auto& [k, v] : config_to_pairs(info.config))
    for (const auto& [k0, v0] : config_to_pairs(defaults))
      if (k == k0 && v != v0 && !(k == "fits" && v == "exact")) r.switches.push_back(k + "=" + v);
  r.stage_seconds = read_train_seconds(run);
  for (const TrainFrame& f : frames) r.frame_names.push_back(f.name);
  const std::vector<EvalVariant> rows = paper_variants(filtered, full);
  const std::vector<size_t> chosen = chosen_rows(o.variants);
  for (size_t i : chosen) {
    const EvalVariant& v = rows[i];
    r.variants.push_back(evaluate_variant(v, frames, opt));
    r.variants.back().paper_row = i;
    if (o.print_table)
      std::printf("  %-15s PSNR %.2f  SSIM %.4f  (%d Gaussians)\n", v.name.c_str(), r.variants.back().psnr,
                  r.variants.back().ssim, r.variants.back().num_gaussians);
  }
  r.regions_full = gaussians_per_region(full.body, full.gaussians);
  r.regions_filtered = gaussians_per_region(filtered.body, filtered.gaussians);
  r.eval_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const RunDir dest(o.out_dir.empty() ? o.run_dir : o.out_dir);
  if (!fs::create_directories(dest.dir, ec) && ec) fail(dest.dir, "--out: cannot create the folder: " + ec.message());
  write_eval_report(r, dest.dir);
  write_eval_contact_sheet(dest.eval_sheet(), r, frames[0].camera.width, frames[0].camera.height);
  return r;
}

}  // namespace haha
