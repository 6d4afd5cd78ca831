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
#include "data/synth_dataset.h"
#include "format/avatar_info.h"
#include "io/image.h"
#include "render/texture_charts.h"
#include "train/texture_evidence.h"
#include "train/train_frame.h"
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

// The --variants keys, with --pose-from's added when missing, and the mesh row for
// --coverage-oracle texel (it measures the coverage the merges then use).
std::vector<std::string> variant_keys(const EvalRunOptions& o) {
  std::vector<std::string> keys = o.variants;
  for (const std::string& k : {o.pose_from, std::string(o.coverage_oracle == "texel" ? "mesh" : "")})
    if (!k.empty() && !keys.empty() && std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
  return keys;
}

EvalOptions::CoverageOracle coverage_oracle_mode(const EvalRunOptions& o) {
  if (o.coverage_oracle.empty()) return EvalOptions::CoverageOracle::none;
  if (o.coverage_oracle == "pixel") return EvalOptions::CoverageOracle::pixel;
  if (o.coverage_oracle != "texel") fail("--coverage-oracle", "expected pixel or texel, got '" + o.coverage_oracle + "'");
  if (o.pose_from == "naive" || o.pose_from == "haha")
    fail("--coverage-oracle", "texel scores the mesh row before the merges: give --pose-from full or mesh");
  return EvalOptions::CoverageOracle::texel;
}

// The rows in the table's order, --pose-from's first (its poses are the others').
std::vector<size_t> scoring_order(std::vector<size_t> rows, const std::string& pose_from) {
  if (pose_from.empty()) return rows;
  const auto* it = std::find(std::begin(kPaperVariantKeys), std::end(kPaperVariantKeys), pose_from);
  if (it == std::end(kPaperVariantKeys))
    fail("--pose-from", "unknown variant '" + pose_from + "' (expected mesh, full, naive or haha)");
  const size_t first = size_t(it - std::begin(kPaperVariantKeys));
  std::stable_partition(rows.begin(), rows.end(), [&](size_t i) { return i == first; });
  return rows;
}

// The part mask of every scored frame (`haha synth --part-masks`: DATA/part_masks/, named as
// the frame's image), resized as the frame was. Throws naming the file when one is missing.
// One part so far (the garment), so the masks need no part name.
void load_part_masks(Dataset& ds, Split split, int resolution, std::vector<TrainFrame>& frames) {
  namespace fs = std::filesystem;
  const std::vector<int> idx = ds.indices(split);
  for (size_t k = 0; k < frames.size(); ++k) {
    const DatasetFrame& f = ds.frames[size_t(idx[k])];
    const fs::path image(f.image_path);
    const std::string file = (image.parent_path().parent_path() / kSynthPartMaskDir / image.filename()).string();
    std::error_code ec;
    if (!fs::exists(file, ec))
      fail(file, "no part mask for this frame (write the dataset with haha synth --part-masks)");
    const Image mask = read_image(file);
    if (mask.width != f.image.width || mask.height != f.image.height)
      fail(file, "the part mask's size differs from the frame's");
    // Resized exactly as the frame's person mask was: the mask channel of a train frame.
    frames[k].part = make_train_frame(file, f.camera, f.params, f.image, mask, resolution).mask;
  }
}

}  // namespace

EvalReport run_eval(const EvalRunOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  scoring_order(chosen_rows(variant_keys(o)), o.pose_from);  // a bad key fails before minutes of loading
  coverage_oracle_mode(o);
  if (o.background != "black" && o.background != "white")
    fail("--background", "expected black or white, got '" + o.background + "'");
  const Split split = parse_split(o.split, "--split");
  if (!o.part.empty() && o.part != "garment") fail("--part", "unknown part '" + o.part + "' (expected garment)");
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!o.out_dir.empty() && fs::exists(o.out_dir, ec) && !fs::is_directory(o.out_dir, ec))
    fail(o.out_dir, "--out: exists and is not a folder");
  const RunDir run(o.run_dir);
  const RunInfo info = read_trained_run_info(run, "haha eval");
  const std::string data = o.data_dir.empty() ? info.data_path : o.data_dir;
  // Avatars: the final (filtered) one and the stage-1 (full Gaussian) one, same body.
  Avatar filtered = load_run_avatar(run);
  Avatar full = load_stage1_avatar(run, filtered.body);
  if (o.depth_margin >= 0) {  // the merge scored with another depth test than the run trained with
    if (!(o.depth_margin <= kMaxDepthMargin)) fail("--depth-margin", "must be a number of metres in [0, 1]");
    filtered.depth_margin = full.depth_margin = float(o.depth_margin);
  }
  Dataset ds = read_dataset(data, LoadPixels::headers);
  const int resolution = scoring_resolution(ds, info.config, o.resolution);
  std::vector<TrainFrame> frames = dataset_frames(ds, split, resolution);
  if (frames.empty())
    fail(data, "no " + o.split + " frames" +
                   (split == Split::unseen ? std::string(" (write the dataset with haha synth --unseen)") : ""));
  if (o.frames > 0 && size_t(o.frames) < frames.size()) frames.resize(size_t(o.frames));
  if (!o.part.empty()) load_part_masks(ds, split, resolution, frames);

  EvalOptions opt = eval_options_of(info.config);
  if (o.tto_steps >= 0) opt.tto_steps = o.tto_steps;
  if (o.tto_resolution >= 0) opt.tto_resolution = o.tto_resolution;
  const float bgv = o.background == "white" ? 1.0f : 0.0f;
  for (float& c : opt.background) c = bgv;
  opt.premultiplied = dataset_premultiplied(ds, info.config.premultiplied);
  opt.keep_images = o.sheet_frames;
  if (o.antialias < -1 || o.antialias > 1) fail("--antialias", "expected -1 (the run's), 0 or 1");
  if (o.antialias >= 0) opt.antialias = o.antialias == 1;
  opt.coverage_oracle = coverage_oracle_mode(o);
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
  r.part = o.part;
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
  if (o.depth_margin >= 0) {
    char m[48];
    std::snprintf(m, sizeof m, "eval depth margin=%g", o.depth_margin);
    r.switches.push_back(m);
  }
  if (!o.pose_from.empty()) r.switches.push_back("eval poses from " + o.pose_from);
  if (!o.coverage_oracle.empty()) r.switches.push_back("eval mesh coverage oracle " + o.coverage_oracle);
  r.stage_seconds = read_train_seconds(run);
  for (const TrainFrame& f : frames) r.frame_names.push_back(f.name);
  const std::vector<EvalVariant> rows = paper_variants(filtered, full);
  const std::vector<size_t> chosen = scoring_order(chosen_rows(variant_keys(o)), o.pose_from);
  std::vector<SmplxParams> shared;  // --pose-from: the first variant's poses
  std::vector<float> texels;        // --coverage-oracle texel: the mesh row's coverage
  for (size_t i : chosen) {
    const EvalVariant& v = rows[i];
    r.variants.push_back(evaluate_variant(v, frames, opt));
    r.variants.back().paper_row = i;
    if (!o.pose_from.empty() && !opt.poses) {
      shared = r.variants.back().poses;
      opt.poses = &shared;
    }
    if (!r.variants.back().texel_coverage.empty()) {  // the mesh row of --coverage-oracle texel
      texels = r.variants.back().texel_coverage;
      opt.texel_coverage = &texels;
    }
    if (o.print_table) {
      const VariantEval& e = r.variants.back();
      std::printf("  %-15s PSNR %.2f  person %.2f  SSIM %.4f  (%d Gaussians)", v.name.c_str(), e.psnr,
                  e.psnr_person, e.ssim, e.num_gaussians);
      if (!o.part.empty())
        std::printf("  %s PSNR %.2f, transmittance %.2f%%", o.part.c_str(), e.psnr_part, 100 * e.transmittance_part);
      std::printf("\n");
    }
  }
  if (const auto sp = avatar_texture_speckle(filtered)) {
    r.has_speckle = true;
    r.speckle = *sp;
    const std::vector<float> e = read_texture_evidence(run, filtered.texture.width);
    if (!e.empty() && filtered.texture.width == filtered.texture.height) {
      r.evidence_full = info.config.s2.evidence_full;
      r.low_evidence_share = evidence_share_below(e, texture_charts(filtered.body, filtered.texture.width,
                                                                   filtered.texture.height), r.evidence_full);
    }
    if (o.print_table)
      std::printf("  texture speckle per mille: neck %.1f, hands %.1f, feet %.1f (all charts %.1f)\n", sp->per_mille[0],
                  sp->per_mille[1], sp->per_mille[2], sp->all_per_mille);
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
