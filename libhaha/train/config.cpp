#include "train/config.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "body/avatar.h"
#include "core/error.h"
#include "train/levels.h"

namespace haha {

namespace {

void add_weights(std::vector<ConfigEntry>& v, const std::string& prefix, LossWeights& w) {
  using K = ConfigEntry::Kind;
  v.push_back({prefix + ".w.l2", K::Double, &w.l2, "weight of the L2 loss"});
  v.push_back({prefix + ".w.ssim", K::Double, &w.ssim, "weight of 1 - SSIM"});
  v.push_back({prefix + ".w.sobel", K::Double, &w.sobel, "weight of the edge (Sobel) loss"});
  v.push_back({prefix + ".w.lpips", K::Double, &w.lpips, "weight of LPIPS-VGG (needs --lpips-weights)"});
  v.push_back({prefix + ".w.knn", K::Double, &w.knn, "weight of the KNN regulariser"});
  v.push_back({prefix + ".w.dice", K::Double, &w.dice, "weight of the silhouette Dice loss"});
  v.push_back({prefix + ".w.tv", K::Double, &w.tv, "weight of the texture TV"});
  v.push_back({prefix + ".w.opacity", K::Double, &w.opacity, "weight of the opacity regulariser"});
}

// Levenshtein distance, for "did you mean" on unknown keys.
int edit_distance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = int(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = int(i);
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// The garment's and the clothed surface's keys (stage 0, before the Gaussians).
void add_garment_and_surface_entries(Stage0Config& s0, std::vector<ConfigEntry>& v) {
  using K = ConfigEntry::Kind;
  Stage0Config::Garment& gm = s0.garment;
  v.push_back({"s0.garment.mode", K::String, &gm.mode,
               "garment around both legs: auto (from the masks), skirt (always), none (never)"});
  v.push_back({"s0.garment.fill", K::Double, &gm.fill, "garment: share of the between-legs pixels in the mask that means one"});
  v.push_back({"s0.garment.max_edge", K::Double, &gm.max_edge,
               "garment: widest hem edge (fill falling 0.8 -> 0.2) as a share of hip-to-ankle; wider is a trouser crotch"});
  v.push_back({"s0.garment.max_frames", K::Int, &gm.max_frames, "garment: frames measured for the decision"});
  v.push_back({"s0.garment.rings", K::Int, &gm.rings, "garment: rings from the waist to the hem"});
  v.push_back({"s0.garment.columns", K::Int, &gm.columns, "garment: vertices around each ring"});
  v.push_back({"s0.garment.chart", K::Double, &gm.chart, "garment: share of the texture's width for its chart"});
  v.push_back({"s0.garment.legs", K::Double, &gm.legs,
               "garment: the legs' share of the hem's skin weights, growing from 0 at the waist (the rest: the torso)"});
  v.push_back({"s0.garment.max_out", K::Double, &gm.max_out, "garment: largest outward move in the fit (metres)"});
  v.push_back({"s0.garment.steps", K::Int, &gm.steps, "garment: fit steps when the clothed surface is off"});
  v.push_back({"s0.garment.lr", K::Double, &gm.lr, "garment: displacement lr at the start of the fit (metres)"});
  v.push_back({"s0.garment.lr_final", K::Double, &gm.lr_final, "garment: displacement lr at the end of the fit"});
  v.push_back({"s0.garment.w.laplacian", K::Double, &gm.w_laplacian, "garment: smoothness weight in the fit"});
  Stage0Config::Surface& sf = s0.surface;
  v.push_back({"s0.surface.steps", K::Int, &sf.steps,
               "clothed surface: displacement of the rest body fitted before stage 1, steps in all (0 = off)"});
  v.push_back({"s0.surface.resolution", K::Int, &sf.resolution, "clothed surface: longer image side (at most the training one)"});
  v.push_back({"s0.surface.levels", K::String, &sf.levels, "clothed surface: image pyramid shares, coarsest first"});
  v.push_back({"s0.surface.warmup", K::Double, &sf.warmup, "clothed surface: share of steps training the texture alone"});
  v.push_back({"s0.surface.lr", K::Double, &sf.lr, "clothed surface: displacement lr at the start (metres)"});
  v.push_back({"s0.surface.lr_final", K::Double, &sf.lr_final, "clothed surface: displacement lr at the end"});
  v.push_back({"s0.surface.lr.texture", K::Double, &sf.lr_texture, "clothed surface: texture lr at the start"});
  v.push_back({"s0.surface.lr.texture_final", K::Double, &sf.lr_texture_final, "clothed surface: texture lr at the end"});
  v.push_back({"s0.surface.texture_size", K::Int, &sf.texture_size, "clothed surface: texture side at the finest level"});
  v.push_back({"s0.surface.max_out", K::Double, &sf.max_out, "clothed surface: largest outward displacement (metres)"});
  v.push_back({"s0.surface.max_held", K::Double, &sf.max_held,
               "clothed surface: largest outward displacement of hands, feet, jaw and eyes (metres)"});
  v.push_back({"s0.surface.max_in", K::Double, &sf.max_in, "clothed surface: largest inward displacement (metres)"});
  v.push_back({"s0.surface.w.silhouette", K::Double, &sf.w_silhouette, "clothed surface: weight of the mask mismatch"});
  v.push_back({"s0.surface.w.outside", K::Double, &sf.outside,
               "clothed surface: the mask mismatch's weight where the surface covers background, times "
               "s0.surface.w.silhouette (> 1 keeps the surface inside the person's outline)"});
  v.push_back({"s0.surface.w.photo", K::Double, &sf.w_photo, "clothed surface: weight of the colour error"});
  v.push_back({"s0.surface.w.laplacian", K::Double, &sf.w_laplacian, "clothed surface: weight of the smoothness"});
  v.push_back({"s0.surface.w.shrink", K::Double, &sf.w_shrink, "clothed surface: weight of the pull back to the body"});
  v.push_back({"s0.surface.part_clearance", K::Bool, &sf.part_clearance,
               "clothed surface: no body part grows over another (an arm at the side) in any frame"});
}

}  // namespace

std::vector<ConfigEntry> config_entries(TrainConfig& c) {
  using K = ConfigEntry::Kind;
  std::vector<ConfigEntry> v;
  v.push_back({"preset", K::String, &c.preset, "preset the run started from (informative)"});
  v.push_back({"seed", K::Uint64, &c.seed, "seed of every random choice (frame order, backgrounds, splits)"});
  v.push_back({"resolution", K::Int, &c.resolution, "longer image side for training (0 = dataset's)"});
  v.push_back({"max_resolution", K::Int, &c.max_resolution, "cap on the longer training side (0 = none)"});
  v.push_back({"batch", K::Int, &c.batch, "frames per step"});
  v.push_back({"face_scale_divisor", K::Double, &c.face_scale_divisor, "face scale k is divided by this"});
  v.push_back({"scale_max", K::Double, &c.scale_max, "scale activation s = scale_max * sigmoid(logit)"});
  v.push_back({"premultiplied", K::String, &c.premultiplied,
               "images already on black with soft masks (auto: datasets made by haha synth)"});
  v.push_back({"fits", K::String, &c.fits,
               "SMPL-X fits: auto (dataset.json's flag), exact, or estimated (adds the settings for estimated fits)"});
  v.push_back({"checkpoint_every", K::Int, &c.checkpoint_every, "steps between checkpoints (0 = stage ends only)"});
  v.push_back({"log_every", K::Int, &c.log_every, "steps between progress lines"});
  v.push_back({"random_background", K::Bool, &c.random_background, "random background colour in stages 1 and 3"});
  v.push_back({"lpips_crop", K::Int, &c.lpips_crop,
               "side of the square crop around the person the LPIPS loss sees, as the authors (0 = whole frame)"});

  Stage0Config& s0 = c.s0;
  v.push_back({"s0.steps", K::Int, &s0.steps, "pose pre-fit to the masks: steps per frame (0 = off)"});
  v.push_back({"s0.lr", K::Double, &s0.lr, "pose pre-fit lr"});
  v.push_back({"s0.w.outside", K::Double, &s0.w_outside, "pose pre-fit: weight of body outside the mask"});
  v.push_back({"s0.w.inside", K::Double, &s0.w_inside, "pose pre-fit: weight of mask not covered"});
  v.push_back({"s0.w.prior", K::Double, &s0.w_prior, "pose pre-fit: weight of the squared change from the fit"});
  v.push_back({"s0.window", K::Int, &s0.window,
               "pose pre-fit: temporal prior, anchor = fit averaged over +-N consecutive frames (0 = own fit)"});
  Stage0Config::Photo& ph = s0.photo;
  v.push_back({"s0.photo.steps", K::Int, &ph.steps,
               "photometric pose fit against a textured mesh before stage 1: steps in all, a frame each (0 = off)"});
  v.push_back({"s0.photo.resolution", K::Int, &ph.resolution,
               "photometric pose fit: longer image side (0 = the training resolution; at most the dataset's)"});
  v.push_back({"s0.photo.warmup", K::Double, &ph.warmup, "photometric pose fit: share of steps training the texture alone"});
  v.push_back({"s0.photo.lr", K::Double, &ph.lr, "photometric pose fit: pose lr"});
  v.push_back({"s0.photo.lr.betas", K::Double, &ph.lr_betas, "photometric pose fit: lr of the shared shape (0 = as fitted)"});
  v.push_back({"s0.photo.lr.texture", K::Double, &ph.lr_texture, "photometric pose fit: texture lr at the start"});
  v.push_back({"s0.photo.lr.texture_final", K::Double, &ph.lr_texture_final, "photometric pose fit: texture lr at the end"});
  v.push_back({"s0.photo.texture_size", K::Int, &ph.texture_size, "photometric pose fit: texture side at the finest level"});
  v.push_back({"s0.photo.levels", K::String, &ph.levels, "photometric pose fit: image pyramid shares, coarsest first"});
  v.push_back({"s0.photo.w.prior", K::Double, &ph.w_prior,
               "photometric pose fit: weight of the squared change of the pose from its anchor"});
  v.push_back({"s0.photo.w.ssim", K::Double, &ph.w_ssim, "photometric pose fit: weight of 1 - SSIM beside the L2"});
  v.push_back({"s0.photo.w.sobel", K::Double, &ph.w_sobel, "photometric pose fit: weight of the edge loss beside the L2"});
  add_garment_and_surface_entries(s0, v);

  Stage1Config& s1 = c.s1;
  v.push_back({"s1.steps", K::Int, &s1.steps, "stage 1 steps (Gaussians + pose refinement)"});
  v.push_back({"s1.lr.offset_init", K::Double, &s1.lr_offset_init, "position lr at the stage start"});
  v.push_back({"s1.lr.offset_final", K::Double, &s1.lr_offset_final, "position lr at the stage end"});
  v.push_back({"s1.lr.rotation", K::Double, &s1.lr_rotation, "rotation lr"});
  v.push_back({"s1.lr.scale", K::Double, &s1.lr_scale, "scale (logit) lr"});
  v.push_back({"s1.lr.color", K::Double, &s1.lr_color, "colour (logit) lr"});
  v.push_back({"s1.lr.pose", K::Double, &s1.lr_pose, "global orient / body pose / transl / betas lr"});
  v.push_back({"s1.lr.pose_fine", K::Double, &s1.lr_pose_fine, "jaw / hand pose lr"});
  v.push_back({"s1.lr.pose_final", K::Double, &s1.lr_pose_final,
               "pose lr at the stage end, log-linear from s1.lr.pose (fine rates scaled alike); 0 = constant"});
  v.push_back({"s1.lr.pose_level_exp", K::Double, &s1.lr_pose_level_exp,
               "coarse to fine: pose rates times (level side / full side)^this (0 = the same at every level)"});
  v.push_back({"s1.lr.betas_scale", K::Double, &s1.lr_betas_scale,
               "the shared betas' rate as a multiple of s1.lr.pose (0 = betas stay as fitted)"});
  v.push_back({"s1.refine_pose", K::Bool, &s1.refine_pose, "refine per-frame SMPL-X pose, transl and betas"});
  v.push_back({"s1.opacity", K::Double, &s1.opacity, "fixed opacity of stage 1"});
  v.push_back({"s1.init_scale", K::Double, &s1.init_scale, "initial local scale (units of k)"});
  v.push_back({"s1.init_color", K::Double, &s1.init_color, "initial colour (grey level)"});
  add_weights(v, "s1", s1.w);
  v.push_back({"s1.densify.from", K::Int, &s1.densify_from, "first densification step"});
  v.push_back({"s1.densify.until", K::Int, &s1.densify_until, "no densification at or after this step"});
  v.push_back({"s1.densify.every", K::Int, &s1.densify_every, "steps between densifications (0 = off)"});
  v.push_back({"s1.densify.grad", K::Double, &s1.densify_grad, "mean screen-space gradient threshold (NDC)"});
  v.push_back({"s1.densify.clone_scale", K::Double, &s1.densify_clone_scale, "max local scale for clone (else split)"});
  v.push_back({"s1.densify.split_div", K::Double, &s1.densify_split_div, "split children's scale divisor"});
  v.push_back({"s1.densify.split_std", K::Double, &s1.densify_split_std, "split offset std (times scale)"});
  v.push_back({"s1.w.stretch", K::Double, &s1.w.stretch,
               "weight of the stretch regulariser: Gaussians of faces that stretch as the arms move stay small and "
               "close to their face (train/face_stretch.h)"});
  v.push_back({"s1.max_gaussians", K::Int, &s1.max_gaussians, "densification stops at this count"});
  v.push_back({"s1.levels", K::String, &s1.levels,
               "coarse to fine: shares of the steps per level, coarsest first, each level twice the side of the "
               "one before, the last at full size (\"6,3,1\"; empty = all at full size)"});
  v.push_back({"s1.knn.k", K::Int, &s1.knn_k, "KNN regulariser set size (self + k-1 neighbours)"});
  v.push_back({"s1.knn.every", K::Int, &s1.knn_every, "steps between neighbour-set updates"});

  Stage2Config& s2 = c.s2;
  v.push_back({"s2.steps", K::Int, &s2.steps, "stage 2 steps (texture)"});
  v.push_back({"s2.lr.texture", K::Double, &s2.lr_texture, "texture lr"});
  v.push_back({"s2.lr.texture_final", K::Double, &s2.lr_texture_final,
               "texture lr at the stage end, log-linear from s2.lr.texture; 0 = constant"});
  v.push_back({"s2.texture_size", K::Int, &s2.texture_size, "texture side in texels"});
  v.push_back({"s2.init_color", K::Double, &s2.init_color, "initial texture grey level"});
  v.push_back({"s2.levels", K::String, &s2.levels,
               "coarse to fine as s1.levels; the texture side halves per coarser level and is upsampled as the images grow"});
  add_weights(v, "s2", s2.w);
  v.push_back({"s2.evidence.full", K::Double, &s2.evidence_full,
               "texture evidence (frontal pixels seen) at which a texel is kept as trained"});
  v.push_back({"s2.evidence.smooth", K::Double, &s2.smooth,
               "weight of the smoothness prior on texels below s2.evidence.full (0 = off)"});
  v.push_back({"s2.evidence.fill", K::Bool, &s2.fill,
               "after stage 2: fill texels below s2.evidence.full from their seen neighbours, dilate the gutter"});
  v.push_back({"s2.evidence.fill_iterations", K::Int, &s2.fill_iterations, "Gauss-Seidel sweeps of the fill"});
  v.push_back({"s2.coverage", K::Bool, &s2.coverage,
               "after stage 2: learn the mesh's coverage from the mattes and cut the mesh where it covers background"});

  Stage3Config& s3 = c.s3;
  v.push_back({"s3.steps", K::Int, &s3.steps, "stage 3 steps (opacity / colour filtering)"});
  v.push_back({"s3.lr.opacity", K::Double, &s3.lr_opacity, "opacity (logit) lr"});
  v.push_back({"s3.lr.color", K::Double, &s3.lr_color, "colour (logit) lr"});
  add_weights(v, "s3", s3.w);
  v.push_back({"s3.opacity_mode", K::OpacityMode, &s3.opacity_mode, "opacity regulariser: sum_squares | mean_abs"});
  v.push_back({"s3.prune_threshold", K::Double, &s3.prune_threshold, "Gaussians below this opacity are deleted"});
  v.push_back({"s3.prune_every", K::Int, &s3.prune_every, "steps between prunes (and at the stage end)"});
  v.push_back({"s3.prune_cost", K::Double, &s3.prune_cost,
               "also delete Gaussians whose deletion changes the merged images less than this "
               "(millionths of a frame's pixels, mean over the frames since the last prune; 0 = off)"});
  v.push_back({"s3.validation_every", K::Int, &s3.validation_every,
               "hold every Nth training frame out of training; the filtering stops on the point those views choose "
               "(0 = the fixed weight's result)"});
  v.push_back({"s3.validation_tto", K::Bool, &s3.validation_tto,
               "with validation: fit the validation views' poses at the start of stage 3 (eval.tto_steps)"});
  v.push_back({"s3.stop_db", K::Double, &s3.stop_db,
               "with validation: the fewest Gaussians within this many dB of the best validation PSNR"});
  v.push_back({"s3.max_kept", K::Double, &s3.max_kept,
               "with validation: the chosen point keeps at most this fraction of stage 1's Gaussians"});
  v.push_back({"s3.depth_margin", K::Double, &s3.depth_margin, "depth test margin in metres (0 = exact)"});
  v.push_back({"s3.levels", K::String, &s3.levels, "coarse to fine as s1.levels"});

  v.push_back({"use_sobel", K::Bool, &c.use_sobel, "ablation switch: edge loss"});
  v.push_back({"use_opacity_reg", K::Bool, &c.use_opacity_reg, "ablation switch: opacity regulariser"});
  v.push_back({"use_dice", K::Bool, &c.use_dice, "ablation switch: silhouette Dice"});
  v.push_back({"eval.tto_steps", K::Int, &c.eval_tto_steps, "test-time pose optimisation steps"});
  v.push_back({"eval.tto_resolution", K::Int, &c.eval_tto_resolution,
               "test-time pose optimisation: 3/4 of its steps on the frames downscaled to this longer side, the rest "
               "at the scored size (0 = all at the scored size)"});
  v.push_back({"eval.antialias", K::Bool, &c.eval_antialias,
               "antialiased mesh silhouette in evaluation (haha eval --antialias / --no-antialias win)"});
  v.push_back({"eval.lr.pose", K::Double, &c.eval_lr_pose, "test-time body pose / transl lr"});
  v.push_back({"eval.lr.pose_fine", K::Double, &c.eval_lr_pose_fine, "test-time jaw / hand lr"});
  v.push_back({"max_cache_mb", K::Double, &c.max_cache_mb, "memory for per-frame mesh caches (MB)"});
  v.push_back({"nan_patience", K::Int, &c.nan_patience, "consecutive non-finite steps before the run stops"});
  return v;
}

std::string config_value_string(const ConfigEntry& e) {
  char buf[64];
  switch (e.kind) {
    case ConfigEntry::Kind::Int:
      return std::to_string(*static_cast<int*>(e.ptr));
    case ConfigEntry::Kind::Uint64:
      return std::to_string(*static_cast<uint64_t*>(e.ptr));
    case ConfigEntry::Kind::Double: {
      // Shortest of %.15g / %.16g / %.17g that reads back exactly.
      const double v = *static_cast<double*>(e.ptr);
      for (int prec : {15, 16, 17}) {
        std::snprintf(buf, sizeof buf, "%.*g", prec, v);
        if (std::strtod(buf, nullptr) == v) break;
      }
      return buf;
    }
    case ConfigEntry::Kind::Bool:
      return *static_cast<bool*>(e.ptr) ? "true" : "false";
    case ConfigEntry::Kind::String:
      return *static_cast<std::string*>(e.ptr);
    case ConfigEntry::Kind::OpacityMode:
      return *static_cast<OpacityRegMode*>(e.ptr) == OpacityRegMode::SumSquares ? "sum_squares" : "mean_abs";
  }
  return "";
}

const char* preset_names() { return "tiny, standard, paper"; }

namespace {

// The CPU demo: 128 px, one frame per step, a few hundred steps per stage. Learning rates of
// the Gaussians are raised so that the short schedule moves them as far as the long one.
TrainConfig tiny_preset(TrainConfig c) {
  c.resolution = 128;
  c.batch = 1;
  c.checkpoint_every = 100;
  c.log_every = 25;
  c.s1.steps = 1000;
  c.s1.lr_offset_init = 1.6e-3;
  c.s1.lr_offset_final = 1.6e-5;
  c.s1.lr_rotation = 1e-2;
  c.s1.lr_scale = 1e-2;
  c.s1.lr_color = 2e-2;
  c.s1.lr_pose = 5e-4;
  c.s1.lr_pose_fine = 5e-5;
  c.s1.densify_from = 50;
  c.s1.densify_until = 800;
  c.s1.densify_every = 100;
  c.s1.max_gaussians = 40000;
  c.s1.knn_every = 10;
  c.s2.steps = 600;
  c.s2.lr_texture = 0.03;
  c.s2.texture_size = 256;
  c.s3.steps = 600;
  c.s3.prune_every = 100;
  c.eval_tto_steps = 20;
  c.eval_lr_pose = 3e-3;
  return c;
}

// Real use on a CPU: the video's size up to 512 px, otherwise tiny's rates and stage-1
// schedule. Coarse to fine where it was measured to pay (docs/results.md "Sharp at 512 px"):
// the texture doubles with the images from 256^2 to 1024^2 over three levels, half its steps
// at a quarter and half of the size (cheap there), its rate decaying so that texels seen
// rarely do not stay speckled. The Gaussians train at full size (at lower levels they settle
// on poses refined against coarse pixels and lose 0.3-0.6 dB at 512 px), and so does the
// filtering, given more steps: what a coarse image does not need, the full one may.
TrainConfig standard_preset(TrainConfig c) {
  c = tiny_preset(c);
  c.resolution = 0;
  c.max_resolution = 512;
  c.checkpoint_every = 250;
  c.log_every = 50;
  c.s2.steps = 3000;
  c.s2.levels = "1,1,2";
  c.s2.lr_texture_final = 3e-4;
  c.s2.texture_size = 1024;
  c.s3.steps = 800;
  return c;
}

}  // namespace

TrainConfig make_preset(const std::string& name) {
  TrainConfig c;
  c.preset = name;
  if (name == "paper") return c;
  if (name == "standard") return standard_preset(c);
  if (name != "tiny") fail("--preset", "unknown preset '" + name + "' (" + preset_names() + ")");
  return tiny_preset(c);
}

void set_config_value(TrainConfig& c, const std::string& key, const std::string& value, const std::string& where) {
  std::vector<ConfigEntry> entries = config_entries(c);
  const ConfigEntry* e = nullptr;
  for (const ConfigEntry& x : entries)
    if (x.key == key) e = &x;
  if (!e) {
    std::string best;
    int best_d = 1 << 30;
    for (const ConfigEntry& x : entries) {
      const int d = edit_distance(key, x.key);
      if (d < best_d) best_d = d, best = x.key;
    }
    fail(where, key + ": unknown key" + (best_d <= 4 ? " (did you mean '" + best + "'?)" : std::string()));
  }
  auto bad = [&](const std::string& what) { fail(where, key + ": " + what + " '" + value + "'"); };
  const char* b = value.data();
  const char* end = b + value.size();
  switch (e->kind) {
    case ConfigEntry::Kind::Int: {
      int v = 0;
      auto r = std::from_chars(b, end, v);
      if (value.empty() || r.ec != std::errc() || r.ptr != end) bad("expected an integer, got");
      *static_cast<int*>(e->ptr) = v;
      break;
    }
    case ConfigEntry::Kind::Uint64: {
      uint64_t v = 0;
      auto r = std::from_chars(b, end, v);
      if (value.empty() || r.ec != std::errc() || r.ptr != end) bad("expected a non-negative integer, got");
      *static_cast<uint64_t*>(e->ptr) = v;
      break;
    }
    case ConfigEntry::Kind::Double: {
      errno = 0;
      char* stop = nullptr;
      const double v = std::strtod(value.c_str(), &stop);
      if (value.empty() || stop != value.c_str() + value.size() || errno != 0 || !std::isfinite(v))
        bad("expected a finite number, got");
      *static_cast<double*>(e->ptr) = v;
      break;
    }
    case ConfigEntry::Kind::Bool:
      if (value == "true" || value == "1" || value == "on" || value == "yes")
        *static_cast<bool*>(e->ptr) = true;
      else if (value == "false" || value == "0" || value == "off" || value == "no")
        *static_cast<bool*>(e->ptr) = false;
      else
        bad("expected true or false, got");
      break;
    case ConfigEntry::Kind::String:
      *static_cast<std::string*>(e->ptr) = value;
      break;
    case ConfigEntry::Kind::OpacityMode:
      if (value == "sum_squares")
        *static_cast<OpacityRegMode*>(e->ptr) = OpacityRegMode::SumSquares;
      else if (value == "mean_abs")
        *static_cast<OpacityRegMode*>(e->ptr) = OpacityRegMode::MeanAbs;
      else
        bad("expected sum_squares or mean_abs, got");
      break;
  }
}

void apply_overrides(TrainConfig& c, const std::vector<std::string>& kv, const std::string& where) {
  for (const std::string& s : kv) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0) fail(where, "'" + s + "': expected key=value");
    set_config_value(c, s.substr(0, eq), s.substr(eq + 1), where);
  }
}

void validate_config(const TrainConfig& c) {
  auto need = [](bool ok, const std::string& key, const std::string& what) {
    if (!ok) fail("config", key + ": " + what);
  };
  TrainConfig copy = c;
  for (const ConfigEntry& e : config_entries(copy)) {
    if (e.kind == ConfigEntry::Kind::Double) {
      const double v = *static_cast<double*>(e.ptr);
      need(std::isfinite(v) && v >= 0, e.key, "must be finite and >= 0");
    } else if (e.kind == ConfigEntry::Kind::Int) {
      need(*static_cast<int*>(e.ptr) >= 0, e.key, "must be >= 0");
    }
  }
  need(c.batch >= 1, "batch", "must be >= 1");
  need(c.resolution == 0 || c.resolution >= 16, "resolution", "must be 0 or >= 16");
  need(c.max_resolution == 0 || c.max_resolution >= 16, "max_resolution", "must be 0 or >= 16");
  make_level_schedule(c.s0.photo.levels, c.s0.photo.steps, "s0.photo.levels");
  need(c.s0.photo.warmup <= 1, "s0.photo.warmup", "must be a share in [0, 1]");
  need(c.s0.photo.steps == 0 || c.s0.photo.texture_size >= 16, "s0.photo.texture_size", "must be >= 16");
  make_level_schedule(c.s0.surface.levels, c.s0.surface.steps, "s0.surface.levels");
  need(c.s0.surface.warmup <= 1, "s0.surface.warmup", "must be a share in [0, 1]");
  need(c.s0.surface.steps == 0 || c.s0.surface.texture_size >= 16, "s0.surface.texture_size", "must be >= 16");
  need(c.s0.surface.steps == 0 || c.s0.surface.resolution >= 16, "s0.surface.resolution", "must be >= 16");
  need(c.s0.surface.max_out <= 0.5 && c.s0.surface.max_held <= c.s0.surface.max_out, "s0.surface.max_out",
       "must be <= 0.5 m and >= s0.surface.max_held");
  need(c.s0.surface.max_in <= 0.05, "s0.surface.max_in", "must be <= 0.05 m");
  const Stage0Config::Garment& gm = c.s0.garment;
  need(gm.mode == "auto" || gm.mode == "skirt" || gm.mode == "none", "s0.garment.mode", "must be auto, skirt or none");
  need(gm.fill > 0 && gm.fill <= 1, "s0.garment.fill", "must be in (0, 1]");
  need(gm.max_edge > 0 && gm.max_edge <= 1, "s0.garment.max_edge", "must be in (0, 1]");
  need(gm.max_frames >= 1, "s0.garment.max_frames", "must be >= 1");
  need(gm.rings >= 2 && gm.rings <= 256 && gm.columns >= 8 && gm.columns <= 1024, "s0.garment.rings",
       "rings in [2, 256], columns in [8, 1024]");
  need(gm.chart > 0 && gm.chart <= 0.5, "s0.garment.chart", "must be in (0, 0.5]");
  need(gm.legs >= 0 && gm.legs <= 1, "s0.garment.legs", "must be in [0, 1]");
  need(gm.max_out >= 0 && gm.max_out <= 0.5, "s0.garment.max_out", "must be in [0, 0.5] m");
  need(gm.steps >= 0, "s0.garment.steps", "must be >= 0");
  need(gm.lr > 0 && gm.lr_final > 0 && gm.w_laplacian >= 0, "s0.garment.lr", "rates > 0, smoothness >= 0");
  make_level_schedule(c.s1.levels, c.s1.steps, "s1.levels");
  make_level_schedule(c.s2.levels, c.s2.steps, "s2.levels");
  make_level_schedule(c.s3.levels, c.s3.steps, "s3.levels");
  need(c.face_scale_divisor > 0, "face_scale_divisor", "must be > 0");
  need(c.scale_max > 0, "scale_max", "must be > 0");
  need(c.s1.opacity > 0 && c.s1.opacity < 1, "s1.opacity", "must be in (0, 1)");
  need(c.s1.init_scale > 0 && c.s1.init_scale < c.scale_max, "s1.init_scale", "must be in (0, scale_max)");
  need(c.s1.init_color > 0 && c.s1.init_color < 1, "s1.init_color", "must be in (0, 1)");
  need(c.s2.init_color >= 0 && c.s2.init_color <= 1, "s2.init_color", "must be in [0, 1]");
  need(c.s1.knn_k >= 2, "s1.knn.k", "must be >= 2 (the set holds the Gaussian itself)");
  need(c.s1.knn_every >= 1, "s1.knn.every", "must be >= 1");
  need(c.s1.densify_split_div > 0, "s1.densify.split_div", "must be > 0");
  need(c.s1.max_gaussians >= 1, "s1.max_gaussians", "must be >= 1");
  need(c.s2.texture_size >= 4 && c.s2.texture_size <= 8192, "s2.texture_size", "must be in [4, 8192]");
  need(c.s2.evidence_full > 0 && std::isfinite(c.s2.evidence_full), "s2.evidence.full", "must be > 0");
  need(c.s2.smooth >= 0 && std::isfinite(c.s2.smooth), "s2.evidence.smooth", "must be >= 0");
  need(c.s2.fill_iterations >= 0 && c.s2.fill_iterations <= 100000, "s2.evidence.fill_iterations",
       "must be in [0, 100000]");
  need(c.s3.prune_threshold < 1, "s3.prune_threshold", "must be < 1");
  need(c.s3.prune_cost >= 0 && std::isfinite(c.s3.prune_cost), "s3.prune_cost", "must be finite and >= 0");
  need(c.s3.validation_every == 0 || c.s3.validation_every >= 2, "s3.validation_every",
       "must be 0 (off) or >= 2 (one frame in N held out)");
  need(c.s3.stop_db >= 0 && std::isfinite(c.s3.stop_db), "s3.stop_db", "must be finite and >= 0");
  need(c.s3.max_kept > 0 && c.s3.max_kept <= 1, "s3.max_kept", "must be in (0, 1]");
  need(c.s3.depth_margin <= kMaxDepthMargin, "s3.depth_margin", "must be <= 1 (metres; the avatar format's limit)");
  need(c.log_every >= 1, "log_every", "must be >= 1");
  need(c.premultiplied == "auto" || c.premultiplied == "true" || c.premultiplied == "false", "premultiplied",
       "must be auto, true or false");
  resolve_estimated_fits(c.fits, "");
}

int train_resolution(const TrainConfig& c, int data_side) {
  const int side = c.resolution > 0 ? c.resolution : data_side;
  return c.max_resolution > 0 ? std::min(side, c.max_resolution) : side;
}

bool resolve_premultiplied(const std::string& setting, bool data_flag) {
  if (setting == "true") return true;
  if (setting == "false") return false;
  return data_flag;
}

std::vector<std::string> estimated_fit_settings(const std::string& preset) {
  const TrainConfig p = make_preset(preset);
  // Ten times the preset's pose rate (tiny: 5e-4 -> 0.005, the measured value; paper:
  // 2e-4 -> 0.002, the same rule, unmeasured): stage 1 repairs fits that are off. Stage 3
  // keeps Gaussians up to 1 cm behind the fitted mesh visible (an estimated mesh often sits
  // in front of the true surface) and filters by what the merged image loses, not by an
  // opacity weight: a prune deletes the Gaussians whose deletion changes the frames less than
  // 0.05 millionths of their pixels (s3.prune_cost) and nothing pushes the rest towards
  // deletion (on the suite's real clips at 512 px, against the doubled opacity weight used
  // before: HAHA +0.13 to +0.49 dB, taiji and tennis within 0.01 dB of their full Gaussians
  // with 36-38% kept; docs/results.md "Filtering judged on the merged image").
  // The poses are first fitted photometrically against a textured mesh, at up to 512 px
  // (train/photo_fit.h; the synthetic room video at 512 px: +0.9 dB; docs/fit-video.md),
  // then the clothed surface (train/surface_fit.h; taiji at 512 px: the mesh +1.8 dB, HAHA
  // as good with 38% fewer Gaussians; docs/results.md "The clothed surface"), kept inside the
  // person's outline (the mask term 4x where it covers background, 1.5 cm inward allowed): an
  // estimated surface overshooting the outline is what the merge loses, and with it inside
  // the naive merge gained 0.10-1.22 dB and HAHA 0.08-1.12 dB on four real clips, the mesh
  // alone 0.33-0.72 dB less on three (docs/results.md "What the merge costs on real footage").
  TrainConfig t = p;
  t.s0.photo.steps = 6000;
  t.s0.surface.steps = 2000;
  t.s0.surface.max_in = 0.015;
  t.s0.surface.outside = 4;
  t.s1.lr_pose = 10 * p.s1.lr_pose;
  t.s3.depth_margin = 0.01;
  t.s3.w.opacity = 0;
  t.s3.prune_cost = 0.05;
  std::vector<std::string> out;
  for (const auto& [k, v] : config_to_pairs(t))
    if (k == "s0.photo.steps" || k == "s0.surface.steps" || k == "s0.surface.max_in" || k == "s0.surface.w.outside" ||
        k == "s1.lr.pose" || k == "s3.depth_margin" || k == "s3.w.opacity" || k == "s3.prune_cost")
      out.push_back(k + "=" + v);
  out.push_back("eval.tto_steps=100");
  out.push_back("eval.antialias=true");
  return out;
}

bool resolve_estimated_fits(const std::string& setting, const std::string& data_fits, const std::string& where) {
  if (setting == "exact") return false;
  if (setting == "estimated") return true;
  if (setting != "auto") fail(where, "fits: must be auto, exact or estimated, got '" + setting + "'");
  return data_fits == "estimated";
}

TrainConfig make_run_config(const std::string& preset, const std::vector<std::string>& overrides,
                            const std::string& data_fits, std::string* summary) {
  TrainConfig c = make_preset(preset);
  apply_overrides(c, overrides, "override");
  const std::string setting = c.fits;
  const bool estimated = resolve_estimated_fits(setting, data_fits, "override");
  const std::string why = setting != "auto"      ? "fits=" + setting
                          : data_fits.empty()     ? "dataset.json does not say"
                                                  : "dataset.json";
  std::string line;
  if (estimated) {
    const std::vector<std::string> bundle = estimated_fit_settings(preset);
    apply_overrides(c, bundle, "estimated-fit settings");
    apply_overrides(c, overrides, "override");  // the user's values win
    // The values in force; the user's own marked.
    line = "fits: estimated (" + why + "):";
    const std::vector<std::pair<std::string, std::string>> now = config_to_pairs(c);
    for (const std::string& kv : bundle) {
      const std::string key = kv.substr(0, kv.find('='));
      for (const auto& [k, v] : now)
        if (k == key) line += " " + k + "=" + v + (kv == k + "=" + v ? "" : " (yours)");
    }
    line += " (override any with key=value; fits=exact for the preset's own)";
  } else {
    line = "fits: exact (" + why + "): the preset's settings (fits=estimated for those of estimated fits)";
  }
  c.fits = estimated ? "estimated" : "exact";
  validate_config(c);
  if (summary) *summary = line;
  return c;
}

std::vector<std::pair<std::string, std::string>> config_to_pairs(const TrainConfig& c) {
  TrainConfig copy = c;
  std::vector<std::pair<std::string, std::string>> out;
  for (const ConfigEntry& e : config_entries(copy)) out.emplace_back(e.key, config_value_string(e));
  return out;
}

}  // namespace haha
