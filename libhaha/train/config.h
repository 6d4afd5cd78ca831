// Every hyperparameter of a HAHA training run (docs/method.md section 3), the two presets and
// key=value overrides. The config is a plain struct; entries() lists each field once with
// its dotted key, so parsing, printing and saving (RUN/config.json, written by the data
// layer) never go out of sync with the struct.
//
// Presets:
//   paper  the published schedule: 3000 / 2500 / 5000 steps, batch 4, 544 px renders, the
//          release's learning rates and loss weights, except two values that were re-measured
//          for this implementation's loss normalisation (s1.densify.grad, s3.w.opacity;
//          see their comments).
//   tiny   the CPU demo: 128 px, batch 1, short stages and proportionally larger learning
//          rates, sized so that `haha synth` + `haha train` + `haha eval` fit in about ten
//          minutes on two cores.
//   standard  real use on a CPU: the video's size (longer side at most 512 px), the texture
//          trained coarse to fine up to 1024^2 with a decaying rate, the Gaussians and the
//          filtering at full size (docs/results.md "Sharp at 512 px").
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "train/losses.h"

namespace haha {

struct LossWeights {
  double l2 = 1.0;
  double ssim = 0.1;     // on (1 - SSIM)
  double sobel = 1.0;    // release edge loss
  double lpips = 0.01;   // only when LPIPS weights are supplied
  double knn = 0.01;
  double dice = 0.1;     // silhouette Dice
  double tv = 0.01;      // texture TV (stage 2)
  double opacity = 0.0;    // opacity regulariser (stage 3 sets its own)
  double stretch = 0.0;    // stretch regulariser (stage 1 only; train/face_stretch.h)
};

// Pose pre-fit to the masks before stage 1 (train/silhouette_fit.h); off by default.
struct Stage0Config {
  int steps = 0;           // per frame
  double lr = 5e-3;        // global orient / body pose / transl
  double w_outside = 1.0;  // body coverage outside the mask
  double w_inside = 0.2;   // mask left uncovered (clothes and hair make it larger than the body)
  double w_prior = 0.01;   // squared change of the pose values (rad) and transl (m) from the fit:
                           // a silhouette leaves many joints unconstrained, Adam would move them anyway
  int window = 0;          // temporal prior: the anchor of that change is the fit averaged over
                           // +-window consecutive training frames (monocular video), not the
                           // frame's own noisy fit; 0 = own fit
  // Photometric pose fit against a textured mesh (train/photo_fit.h), after the mask pre-fit
  // and before stage 1: a mesh cannot absorb a misplaced limb the way free Gaussians do.
  struct Photo {
    int steps = 0;              // in all, one frame each (0 = off)
    int resolution = 512;       // longer side of its images (0 = the training resolution; at most the dataset's)
    double warmup = 0.2;        // share of the steps that train the texture alone
    double lr = 5e-3;           // global orient / body pose / transl
    double lr_betas = 0;        // the video's shared shape (0: as fitted)
    double lr_texture = 0.05, lr_texture_final = 1e-3;  // log-linear decay over the steps
    int texture_size = 512;     // at the finest level, halved per coarser level
    std::string levels = "1,1,1,1";  // image pyramid, as s1.levels (512 px: 64, 128, 256, 512)
    double w_prior = 0.01;      // squared change of the pose values from the anchor (s0.window)
    double w_ssim = 0.3, w_sobel = 1;  // image loss: |I - gt|^2 per pixel + w_ssim (1 - SSIM) + w_sobel edge loss
  } photo;
  // The clothed surface: a displacement of the body's rest vertices along their normals,
  // fitted to the frames' masks and colours after the pose fits, before stage 1
  // (train/surface_fit.h). Every stage, the file and every reader then see the displaced
  // body (BodyModel::rest_offsets).
  struct Surface {
    int steps = 0;              // in all, one frame each (0 = off)
    int resolution = 256;       // longer side of its images (at most the training resolution)
    std::string levels = "1,2";  // image pyramid shares, coarsest first (256 px: 128, 256)
    double warmup = 0.2;        // share of the steps that train the texture alone
    double lr = 1e-3, lr_final = 1e-4;  // metres, log-linear over the steps
    double lr_texture = 0.05, lr_texture_final = 2e-3;
    int texture_size = 256;     // at the finest level, halved per coarser level
    double max_out = 0.08;      // metres outward at most
    double max_held = 0.005;    // ... where hands, feet and the jaw / eyes drive the vertex
    double max_in = 0.003;      // metres inward at most (the fit's body is not too fat)
    double w_silhouette = 1;    // coverage against the mask, both ways (mean over pixels)
    double outside = 1;         // ... times this where the surface covers background (> 1: it stays inside the person)
    double w_photo = 1;         // |I - gt|^2 per pixel over a random background
    double w_laplacian = 3e4;   // mean over vertices of (h - mean of the neighbours' h)^2, metres
    double w_shrink = 1;        // mean over vertices of h^2: what no view asks for stays on the body
    bool part_clearance = true;  // no part grows over another in any frame (train/part_clearance.h)
    // A garment appended to the body (not keys: the run sets them from s0.garment): its
    // vertices move in [0, garment_max_out] at their own rates and smoothness (a flared hem
    // moves far more than a body's displacement); garment_only holds the body's at 0.
    double garment_max_out = 0.2;
    double garment_lr = 4e-3, garment_lr_final = 4e-4, garment_w_laplacian = 3e3;
    bool garment_only = false;
  } surface;
  // A garment around both legs (body/garment.h, train/garment_fit.h): detected from the
  // masks, appended to the body, shaped by the clothed-surface fit before stage 1.
  struct Garment {
    std::string mode = "auto";  // auto (made when the masks fill the space between the legs) | skirt | none
    double fill = 0.5;          // share of the between-legs pixels in the mask that means a garment
    double max_edge = 0.12;     // widest hem edge (fill 0.8 -> 0.2), share of hip-to-ankle; wider: a crotch
    int max_frames = 40;        // frames measured, evenly spread
    int rings = 14, columns = 48;
    double chart = 0.2;         // share of the texture's width for the garment's chart
    double legs = 0.85;         // the legs' share of the hem's skin weights (0 at the waist; body/garment.h)
    double max_out = 0.2;       // largest outward move of a garment vertex in the fit (metres)
    int steps = 400;            // the fit's steps when s0.surface.steps is 0 (the garment alone moves)
    // Its rates and smoothness in the fit, alone or beside the body's displacement (a flared
    // hem moves ~10 cm from the loft it starts as, far more than a body's displacement)
    double lr = 4e-3, lr_final = 4e-4;
    double w_laplacian = 3e3;
  } garment;
};

struct Stage1Config {
  int steps = 3000;
  double lr_offset_init = 1.6e-4, lr_offset_final = 1.6e-6;  // log-linear over the stage
  double lr_rotation = 5e-3, lr_scale = 5e-3, lr_color = 5e-3;
  double lr_pose = 2e-4;       // global orient, body pose, transl, betas
  double lr_pose_fine = 2e-5;  // jaw, hands
  // > 0: both pose rates decay log-linearly over the stage to lr_pose_final / lr_pose of
  // their start (a large early rate repairs fits, a small late one lets the avatar settle);
  // 0: constant.
  double lr_pose_final = 0;
  // Coarse to fine: the pose rates at a level whose side is r times the full size are
  // multiplied by r^lr_pose_level_exp (0: the same rates at every level).
  double lr_pose_level_exp = 0;
  double lr_betas_scale = 1;   // the shared betas' rate is this times the pose rate (0: betas as fitted)
  bool refine_pose = true;
  double opacity = 0.99;       // held fixed during the stage
  double init_scale = 0.015;   // activated local scale at start (units of the face scale k)
  double init_color = 0.5;
  LossWeights w{};
  // Face-bound densification (clone / split, children keep the parent face).
  int densify_from = 100, densify_until = 2500, densify_every = 201;
  // Mean over views of the screen-space gradient norm (3DGS NDC units, each axis its own;
  // a per-view gradient, so the same at any batch size). The release's 5e-5 sits at the
  // median of this statistic with these losses (every other visible Gaussian would
  // densify); 2e-4 is about the 90th percentile on the synthetic subject at batch 1 and 4
  // (tiny preset, measured: docs/results.md "Results on the embedded sample").
  double densify_grad = 2e-4;
  double densify_clone_scale = 0.005;  // max local scale <= this: clone, else split
  double densify_split_div = 1.6;   // split children's scales are divided by this
  double densify_split_std = 0.2;   // split offsets ~ N(0, std * scale), outer side of the face
  int max_gaussians = 200000;
  // Coarse to fine (train/levels.h): the share of the stage's steps at each level of the
  // image pyramid, coarsest first, each level twice the previous one's side, the last at the
  // training resolution ("6,3,1": 60% at a quarter, 30% at half, 10% at full size); empty:
  // every step at the training resolution.
  std::string levels;
  int knn_k = 3;
  int knn_every = 1;                // recompute neighbour sets every n steps (and after densify)
};

struct Stage2Config {
  int steps = 2500;
  double lr_texture = 0.01;
  // > 0: the texture rate decays log-linearly over the stage to this: Adam moves every texel
  // by about the rate each step, so a constant rate leaves texels seen rarely speckled.
  double lr_texture_final = 0;
  int texture_size = 512;        // at the finest level; halved per coarser level, upsampled as the images grow
  double init_color = 0.5;
  std::string levels;            // as s1.levels
  LossWeights w{1.0, 0.1, 0.0, 0.01, 0.0, 0.0, 0.01, 0.0};
  // Texels the frames barely saw (train/texture_evidence.h; evidence in frontal pixels):
  // below evidence_full a texel is smoothed toward its neighbours during the stage (weight
  // `smooth`, train/texture_smooth.h) and, with `fill`, blended after it toward the colour
  // diffused from the seen texels over the surface, the gutter dilated (train/texture_fill.h).
  // Measured on the demo subject (docs/results.md, "The texture where the video barely
  // looked"): smooth 10 takes the speckle from 37-200 to 0-1 per mille and adds 1.3 dB.
  double evidence_full = 1.0;
  double smooth = 10.0;
  bool fill = true;
  int fill_iterations = 300;
  // After the stage: the mesh's coverage learned from the training mattes (train/mesh_coverage.h),
  // the mesh cut where it covers background in most of the frames that saw it; stage 3 and
  // every reader merge with the cut mesh. Off: on the suite's runs it cut under 0.5% of the
  // vertices and moved nothing (docs/results.md, "The mesh's coverage learned").
  bool coverage = false;
};

struct Stage3Config {
  int steps = 5000;
  double lr_opacity = 0.05, lr_color = 5e-3;
  // Stage-1 loss + opacity regulariser + Dice. The paper's 0.001 sum(o^2) outweighs the
  // (pixel-mean) image losses by about 1e3 and deletes every Gaussian (measured); 1e-6 lets
  // the image and Dice terms decide which Gaussians matter. The release's 0.001 mean(|o|) is
  // `opacity_mode = MeanAbs` (measured against this default in the README).
  LossWeights w{1.0, 0.1, 1.0, 0.01, 0.01, 0.1, 0.0, 1e-6};
  OpacityRegMode opacity_mode = OpacityRegMode::SumSquares;
  double prune_threshold = 0.1;  // opacity below this: deleted
  int prune_every = 201;         // and once at the end of the stage
  // > 0: a prune also deletes each Gaussian whose deletion would change the merged images
  // less than this: the mean over the stage-3 frames rendered since the last prune of
  // sum alpha T |colour - what lies behind| over its pixels (render/gaussian_raster.h
  // removal_cost), in millionths of a frame's pixels, each fully changed. It judges a
  // Gaussian by the image users see (hidden by the mesh, or the mesh's colour: it costs
  // nothing), not by its opacity alone. 0: opacity only.
  double prune_cost = 0;
  // > 0: every validation_every-th training frame is held out of all three stages and the
  // filtering ends on the point of its run chosen on those views (train/filter_stop.h): the
  // fewest Gaussians within stop_db of the best PSNR, keeping at most max_kept of stage 1's.
  // 0: the fixed weight's result.
  int validation_every = 0;
  // With validation: the views' poses are fitted once at the start of stage 3 (test-time pose
  // optimisation with the avatar frozen, eval.tto_* as `haha eval` fits a held-out frame),
  // so that their score sees the avatar, not the pose error of the photometric fit.
  bool validation_tto = true;
  double stop_db = 0.1;
  double max_kept = 0.4;
  double depth_margin = 0.0;     // Gaussians with centre z <= D + margin are in front (metres, <= 1)
  std::string levels;            // as s1.levels
};

struct TrainConfig {
  std::string preset = "paper";
  uint64_t seed = 0;
  int resolution = 544;          // longer image side used for training; 0 = the dataset's
  int max_resolution = 0;        // and at most this (0 = no cap): train_resolution()
  int batch = 4;                 // frames per step (gradients averaged)
  double face_scale_divisor = 0.05;
  double scale_max = 0.1;        // scale activation: s = scale_max * sigmoid(logit)
  std::string premultiplied = "auto";  // images already composited on black: auto (dataset.json's flag)|true|false
  std::string fits = "auto";           // SMPL-X fits: auto (dataset.json's flag)|exact|estimated (make_run_config)
  int checkpoint_every = 500;    // steps (plus every stage end)
  int log_every = 50;            // progress lines
  bool random_background = true; // stages 1 and 3
  int lpips_crop = 256;          // LPIPS-VGG loss on a square crop of this side around the person (0 = whole frame)
  Stage0Config s0{};
  Stage1Config s1{};
  Stage2Config s2{};
  Stage3Config s3{};
  // Ablations of the paper's table (they zero the weight wherever it is used).
  bool use_sobel = true, use_opacity_reg = true, use_dice = true;
  // Test-time pose optimisation defaults for `haha eval` (saved with the run).
  int eval_tto_steps = 100;
  int eval_tto_resolution = 0;   // > 0: 3/4 of the test-time pose steps at this longer side (train/evaluate.h)
  bool eval_antialias = false;   // antialiased mesh silhouette (haha eval --antialias / --no-antialias win)
  double eval_lr_pose = 3e-3, eval_lr_pose_fine = 3e-4;
  double max_cache_mb = 2048;    // per-frame caches of stages 2 and 3 (posed mesh rasters)
  int nan_patience = 20;         // consecutive skipped (non-finite) steps before giving up

  int total_steps() const { return s1.steps + s2.steps + s3.steps; }
};

// One field of the config, addressed by its dotted key.
struct ConfigEntry {
  enum class Kind { Int, Uint64, Double, Bool, String, OpacityMode };
  std::string key;
  Kind kind;
  void* ptr;
  std::string help;
};

// Every field of `c` (pointers into it), in a fixed order.
std::vector<ConfigEntry> config_entries(TrainConfig& c);

// The value of an entry as text (doubles in the shortest form that reads back exactly;
// bools "true"/"false").
std::string config_value_string(const ConfigEntry& e);

// The presets' names, for help texts and errors: "tiny, standard, paper".
const char* preset_names();

// "tiny", "standard" or "paper"; throws haha::Error "--preset: unknown preset 'x' (tiny, standard, paper)".
TrainConfig make_preset(const std::string& name);

// Sets one key from text. Throws haha::Error "<where>: <key>: <problem>" for an unknown key
// (with a close match suggested) or an unparsable / out-of-range value.
void set_config_value(TrainConfig& c, const std::string& key, const std::string& value,
                      const std::string& where = "override");

// "key=value" strings, in order; the same errors.
void apply_overrides(TrainConfig& c, const std::vector<std::string>& kv, const std::string& where = "override");

// Checks ranges that span fields (steps >= 0, batch >= 1, lrs >= 0, ...). Throws
// haha::Error "config: <key>: <problem>".
void validate_config(const TrainConfig& c);

// The longer image side a run trains at on data whose longer side is `data_side`: the
// config's `resolution` (0 = the data's), at most `max_resolution` when that is set.
int train_resolution(const TrainConfig& c, int data_side);

// Whether the images count as composited on black with their soft masks under the config's
// `premultiplied` setting: "true" / "false", or for "auto" the data's own flag.
bool resolve_premultiplied(const std::string& setting, bool data_flag);

// The settings for estimated (imperfect) SMPL-X fits on top of `preset`, as key=value
// strings: the pose pre-fit to the masks, ten times the preset's stage-1 pose rate, and
// `haha eval` with 100 steps of test-time pose optimisation on the antialiased silhouette.
// Measured at the tiny preset (docs/results.md "Imperfect fits": 0.05 rad / 2 cm of fit noise
// cost 5.5 dB with the preset's settings, 0.9 dB with these); the paper preset's are the same
// rule (10 x 2e-4) and unmeasured. Throws haha::Error for an unknown preset.
std::vector<std::string> estimated_fit_settings(const std::string& preset);

// Whether a run trains with the settings for estimated fits under the config's `fits`:
// "exact" / "estimated", or for "auto" the dataset's flag (`data_fits`: "exact",
// "estimated", or "" where the dataset does not say, which counts as exact: older datasets
// train as they did). Throws haha::Error "<where>: fits: ..." for any other setting.
bool resolve_estimated_fits(const std::string& setting, const std::string& data_fits,
                            const std::string& where = "config");

// The config of a new run: the preset, the user's key=value overrides, and where the fits
// resolve to estimated, the preset's estimated_fit_settings() with the user's overrides
// applied again over them (the user always wins); `fits` holds the resolved "exact" or
// "estimated", so RUN/config.json says what was trained. Validated (validate_config).
// `summary` (optional) gets one line saying what was picked and why.
TrainConfig make_run_config(const std::string& preset, const std::vector<std::string>& overrides,
                            const std::string& data_fits, std::string* summary = nullptr);

// (key, value) pairs of every entry, in entries() order.
std::vector<std::pair<std::string, std::string>> config_to_pairs(const TrainConfig& c);

}  // namespace haha
