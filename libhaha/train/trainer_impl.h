// The trainer's private state and step functions (train/trainer.h is the public face).
// One file per part: trainer.cpp (set-up, the step loop, the public API),
// trainer_stage1.cpp (Gaussians, pose refinement, densification), trainer_stage2.cpp
// (texture), trainer_stage3.cpp (filtering, pruning), trainer_checkpoint.cpp (state in
// and out), trainer_cuda.cpp (the same steps on the GPU: train/trainer_device.h).
// Included by those files only.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "core/error.h"
#include "core/parallel.h"
#include "render/avatar_render.h"
#include "render/mesh_raster.h"
#include "render/texture.h"
#include "render/texture_charts.h"
#include "train/adam.h"
#include "train/face_stretch.h"
#include "train/filter_stop.h"
#include "train/gaussian_params.h"
#include "train/knn.h"
#include "train/levels.h"
#include "train/losses.h"
#include "train/pose_groups.h"
#include "train/trainer.h"
#include "train/trainer_device.h"

namespace haha {

namespace trainer_detail {

// RNG streams (the stage is folded in).
enum Stream : uint64_t { kFrameOrder = 1, kBackground = 2, kSplit = 3, kLpipsCrop = 4 };
inline uint64_t stream(int stage, Stream s) { return uint64_t(stage) * 16 + uint64_t(s); }

inline bool finite_all(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

inline std::string frame_label(const TrainFrame& f, size_t i) {
  return f.name.empty() ? "training frame " + std::to_string(i) : f.name;
}

}  // namespace trainer_detail

using namespace trainer_detail;  // a private header: only the trainer's files include it

struct Trainer::Impl {
  TrainConfig cfg;
  TrainInput in;
  const BodyModel& body;
  Lbs<float> lbs;
  int W = 0, H = 0, P = 0, nf = 0;  // of the frames of the current level (in.frames)
  std::unique_ptr<LpipsNet<float>> lpips;

  // ---- state (what a checkpoint holds) ----
  int stage = 1, step = 0;
  GaussianParams g, g_s1;
  bool have_s1 = false;
  std::vector<float> betas;
  std::vector<SmplxParams> params;  // per frame; betas are replaced by `betas` at use
  std::vector<float> texture;       // (S, S, 3)
  int tex_size = 0;
  std::vector<float> coverage;      // (V) the mesh's learned coverage (s2.coverage); empty: none
  // Derived from the frozen bodies at the texture's current size (recomputed after a resume or
  // a level change; trainer_texture.cpp): how much the frames saw each texel, its charts and
  // the smoothness prior's per-texel weights.
  std::vector<float> tex_evidence, tex_smooth_w;
  TextureCharts tex_charts;
  Adam adam;
  std::vector<float> grad_accum, grad_count;  // densification statistics
  // Stage 3 with s3.prune_cost: each Gaussian's removal cost summed over the frames rendered
  // since the last prune, and their count.
  std::vector<float> removal_cost;
  double removal_frames = 0;
  std::vector<int32_t> knn_idx;
  // Per face: how much it stretches as the arms move (train/face_stretch.h); set up only
  // when the stretch regulariser is on.
  std::vector<float> face_stretch;
  FilterStop stop;  // where stage 3's filtering ends (validation views; train/filter_stop.h)
  std::array<double, 3> seconds{0, 0, 0};
  int64_t skipped = 0;
  int nan_streak = 0;

  // ---- coarse to fine (train/levels.h; trainer_levels.cpp) ----
  std::array<LevelSchedule, 3> levels;  // per stage
  std::vector<TrainFrame> full_frames;  // the input at the training resolution, when a stage has levels
  int level_stage = 0, level = -1;      // what in.frames and the texture hold now (-1: the input as given)

  // ---- derived / scratch ----
  std::string resume_event;  // what load() did, reported by the next step's event
  std::vector<std::vector<float>> frame_verts;  // stages 2-3: posed bodies (frozen)
  struct MeshCache {
    std::vector<int32_t> tri;
    std::vector<float> uv, mask, depth, color;
    bool ready = false;
  };
  std::vector<MeshCache> mesh_cache;
  bool cache_all = true;
  MeshCache scratch_cache;
  MeshRaster raster;
  ActivatedGaussians act;
  AvatarRenderBuffers rbuf;
  LbsCache<float> lcache;
  std::vector<float> verts, d_verts, gt, d_image, d_alpha, sil, d_sil, rot_unit, d_rot_unit, d_means_extra;
  ImageLossContext lctx;
  std::vector<float> d_offset, d_rotation, d_scale, d_color, d_opacity, d_scale_logit, d_color_logit,
      d_opacity_logit, d_texture, d_betas, tex_color;
  std::vector<std::vector<float>> d_frame_body, d_frame_fine;
  std::vector<uint8_t> frame_touched;
  std::function<void(int, std::vector<float>&)> hook;
  std::function<void(const std::string&, const std::vector<float>&)> pose_hook;

  // ---- device ----
  Device device_kind = Device::cpu;
  std::unique_ptr<TrainerDevice> dev;  // null: the steps run here (CPU)
  bool host_stale = false;             // the device holds newer state than the host
  struct Cuda;  // train/trainer_cuda.cpp (built with the CUDA backend only)
  static std::unique_ptr<TrainerDevice> make_cuda(Impl& t);
  // Makes the host state current (a no-op on the CPU).
  void sync_host() {
    if (dev && host_stale) {
      dev->download();
      host_stale = false;
    }
  }

  Impl(const TrainConfig& c, TrainInput input)
      : cfg(c), in(std::move(input)), body(*in.body), lbs(*in.body) {}

  int stage_steps(int s) const { return s == 1 ? cfg.s1.steps : s == 2 ? cfg.s2.steps : s == 3 ? cfg.s3.steps : 0; }
  const LossWeights& weights(int s) const { return s == 1 ? cfg.s1.w : s == 2 ? cfg.s2.w : cfg.s3.w; }
  LossWeights effective(int s) const {
    LossWeights w = weights(s);
    if (!cfg.use_sobel) w.sobel = 0;
    if (!cfg.use_opacity_reg) w.opacity = 0;
    if (!cfg.use_dice) w.dice = 0;
    if (!lctx.lpips) w.lpips = 0;  // no weights, or this level's images are too small
    return w;
  }

  // Frame of sample k of stage s: epochs are seeded permutations of the frames.
  int frame_of(int s, int64_t k) const { return epoch_draw(cfg.seed, stream(s, kFrameOrder), nf, k); }
  void background(int s, int64_t k, float bg[3]) const {
    for (int c = 0; c < 3; ++c)
      bg[c] = cfg.random_background ? float(uniform01(cfg.seed, stream(s, kBackground), uint64_t(k) * 3 + uint64_t(c))) : 0.0f;
  }

  // Where the LPIPS loss of draw k (stage s, frame fi) looks: a crop around the person at a
  // random point of the mask's bounding box (the whole frame without LPIPS or a crop size).
  void place_lpips_crop(int s, int64_t k, int fi) {
    if (!lctx.lpips || cfg.lpips_crop <= 0) {
      lctx.lpips_window = {};
      return;
    }
    const TrainFrame& f = in.frames[size_t(fi)];
    lctx.lpips_window = person_crop(f.mask.empty() ? nullptr : f.mask.data(), f.camera.height, f.camera.width, cfg.lpips_crop,
                                    uniform01(cfg.seed, stream(s, kLpipsCrop), uint64_t(k) * 2),
                                    uniform01(cfg.seed, stream(s, kLpipsCrop), uint64_t(k) * 2 + 1));
  }

  SmplxParams frame_params(int fi) const {
    SmplxParams p = params[size_t(fi)];
    p.betas = betas;
    return p;
  }

  void pose_frame(int fi, bool keep_cache) {
    verts.resize(3 * size_t(body.num_verts));
    lbs.forward(frame_params(fi), verts.data(), nullptr, keep_cache ? &lcache : nullptr);
  }

  // ---------------------------------------------------------------------------------
  void setup(bool fresh) {
    validate_config(cfg);
    validate_train_input(in);
    W = in.frames[0].camera.width;
    H = in.frames[0].camera.height;
    P = W * H;
    nf = int(in.frames.size());
    if (in.lpips && in.lpips->has_backbone(LpipsBackbone::Vgg16)) {
      lpips = std::make_unique<LpipsNet<float>>(*in.lpips, LpipsBackbone::Vgg16);
      if (std::min(W, H) < lpips->min_size()) lpips.reset();
    }
    lctx.lpips = lpips.get();
    setup_levels();
    betas = video_betas(in.frames, body.num_shape);
    // From the fits' betas (not the refined ones), so a resumed run sees the same weights.
    if (cfg.s1.w.stretch > 0) face_stretch = face_arm_stretch(body, betas, float(cfg.face_scale_divisor));
    params.clear();
    for (const TrainFrame& f : in.frames) {
      SmplxParams p = f.params;
      if (p.expression.size() > size_t(body.num_expr)) p.expression.resize(size_t(body.num_expr));
      params.push_back(p);
    }
    tex_size = cfg.s2.texture_size;  // the texture is made at stage 2's first level (begin_stage)
    d_frame_body.assign(size_t(nf), std::vector<float>(kPoseBodyGroup));
    d_frame_fine.assign(size_t(nf), std::vector<float>(kPoseFineGroup));
    frame_touched.assign(size_t(nf), 0);
    if (fresh) {
      stage = 1;
      step = 0;
      g = init_one_per_face(body.num_faces, float(cfg.s1.init_scale), float(cfg.s1.init_color), float(cfg.s1.opacity),
                            float(cfg.scale_max));
      begin_stage(1);
      set_level(1, levels[0].level_of(0));
    }
  }

  void begin_stage(int s) {
    adam = Adam();
    knn_idx.clear();
    if (s == 1) {
      const int n = g.size();
      adam.add_group("offset", 3 * int64_t(n), cfg.s1.lr_offset_init, 3);
      adam.add_group("rotation", 4 * int64_t(n), cfg.s1.lr_rotation, 4);
      adam.add_group("scale", 3 * int64_t(n), cfg.s1.lr_scale, 3);
      adam.add_group("color", 3 * int64_t(n), cfg.s1.lr_color, 3);
      if (cfg.s1.refine_pose) {
        adam.add_group("betas", int64_t(betas.size()), cfg.s1.lr_pose, 1);
        for (int i = 0; i < nf; ++i) {
          adam.add_group("frame" + std::to_string(i) + ".body", kPoseBodyGroup, cfg.s1.lr_pose, 1);
          adam.add_group("frame" + std::to_string(i) + ".fine", kPoseFineGroup, cfg.s1.lr_pose_fine, 1);
        }
      }
      grad_accum.assign(size_t(n), 0.0f);
      grad_count.assign(size_t(n), 0.0f);
    } else if (s == 2) {
      tex_evidence.clear();
      if (!have_s1) {
        g_s1 = g;
        have_s1 = true;
      }
      if (texture.empty()) {
        tex_size = texture_side(levels[1].level_of(step));
        texture.assign(size_t(tex_size) * tex_size * 3, float(cfg.s2.init_color));
      }
      adam.add_group("texture", int64_t(texture.size()), cfg.s2.lr_texture, 3);
      build_frame_verts();
    } else if (s == 3) {
      if (!texture.empty() && tex_size != cfg.s2.texture_size) {  // stage 2 ended before its finest level
        texture = resample_texture(texture, tex_size, cfg.s2.texture_size);
        tex_size = cfg.s2.texture_size;
      }
      const int n = g.size();
      adam.add_group("opacity", n, cfg.s3.lr_opacity, 1);
      if (validating()) stop.begin(cfg.s3.stop_db, int(cfg.s3.max_kept * (have_s1 ? g_s1.size() : g.size())));
      adam.add_group("color", 3 * int64_t(n), cfg.s3.lr_color, 3);
      reset_removal_cost();
      build_frame_verts();
    }
    for (MeshCache& m : mesh_cache) m.ready = false;
  }

  void build_frame_verts() {
    frame_verts.assign(size_t(nf), {});
    for (int i = 0; i < nf; ++i) {
      frame_verts[size_t(i)].resize(3 * size_t(body.num_verts));
      lbs.forward(frame_params(i), frame_verts[size_t(i)].data(), nullptr, nullptr);
    }
    reset_mesh_cache();
  }

  // Per-frame caches of the current stage and image size: tri + uv + mask (stage 2) or
  // depth + colour + mask (stage 3), all frames when they fit in max_cache_mb.
  void reset_mesh_cache() {
    const double per_frame = double(P) * (stage == 2 ? 4 + 8 + 4 : 4 + 12 + 4);
    cache_all = per_frame * nf <= cfg.max_cache_mb * 1024.0 * 1024.0;
    mesh_cache.assign(cache_all ? size_t(nf) : 0, MeshCache{});
  }

  // ---------------------------------------------------------------------------------
  // Coarse to fine (trainer_levels.cpp).
  void setup_levels();
  int texture_side(int s2_level) const;
  // Makes in.frames (and in stage 2 the texture) those of level `lvl` of stage s, on the
  // host; a device backend must be handed the state afterwards (begin_stage).
  void set_level(int s, int lvl);
  // Before a step: the level its step count asks for (host and device). Returns an event
  // ("level 2/3: 256x256 px") when the images changed size, else "".
  std::string enter_step_level();
  std::string level_note() const;  // "level 1/3: 128x128 px[, texture 256^2]"; "" without levels

  // Mesh data of frame fi for the current stage (cached when memory allows).
  MeshCache& mesh_of(int fi) {
    MeshCache& m = cache_all ? mesh_cache[size_t(fi)] : scratch_cache;
    if (cache_all && m.ready) return m;
    raster_mesh_layer(in.frames[size_t(fi)].camera, frame_verts[size_t(fi)].data(), m);
    m.ready = true;
    return m;
  }

  TextureView texture_view() const { return TextureView{tex_size, tex_size, 3, texture.data()}; }

  GaussianSetView gaussian_view() const {
    GaussianSetView v;
    v.count = g.size();
    v.face = g.face.data();
    v.offset = g.offset.data();
    v.rotation = g.rotation.data();
    v.scale = act.scale.data();
    v.color = act.color.data();
    v.opacity = act.opacity.data();
    return v;
  }

  void prepare_ground_truth(int fi, const float bg[3]) {
    gt.resize(3 * size_t(P));
    const TrainFrame& f = in.frames[size_t(fi)];
    composite_ground_truth(f.rgb.data(), f.mask.data(), P, in.premultiplied, bg, gt.data());
  }

  // KNN sets over the posed centres `means`.
  void update_knn(const float* means) {
    const int n = g.size(), K = cfg.s1.knn_k;
    knn_idx.resize(size_t(n) * K);
    if (n > 0) haha::knn_sets(means, n, K, knn_idx.data());
  }

  // ---------------------------------------------------------------------------------
  // Stage 1.
  bool step1(LossTerms& terms, std::string& event);
  const float* knn_term(const LossWeights& w, bool need_knn, LossTerms& terms);
  void accumulate_pose_grad(int fi);
  void add_pose_grad(int fi, const SmplxGrad<float>& sg);
  bool pose_grads_finite() const;
  void update_stage1();
  void update_pose();
  // After a step's update: densification (stage 1) and pruning (stage 3) when the
  // schedule says so, on the host state (a device backend hands it over and back).
  void after_update(int s, std::string& event);

  void densify(std::string& event);

  // ---------------------------------------------------------------------------------
  // Stage 2.
  bool step2(LossTerms& terms, std::string&);
  // The texture's evidence over every training frame at its current size, with its charts
  // and prior weights, when they are not of that size yet (trainer_texture.cpp).
  void update_texture_evidence();
  // The same, computed afresh (empty without posed training bodies or a texture).
  std::vector<float> compute_texture_evidence() const;
  // Stage 2 ends: low-evidence texels filled from the seen ones, the gutter dilated.
  void finish_texture(std::string& event);
  // The mesh's coverage from the training mattes on the frozen bodies (s2.coverage; after
  // stage 2, or on resuming a stage-3 run that has none).
  void learn_coverage(std::string& event);
  double texture_lr() const {  // of this step (s2.lr.texture_final)
    const Stage2Config& s2 = cfg.s2;
    return s2.lr_texture_final > 0 ? LogLinearLr{s2.lr_texture, s2.lr_texture_final, s2.steps}(step) : s2.lr_texture;
  }

  // ---------------------------------------------------------------------------------
  // Stage 3.
  bool step3(LossTerms& terms, std::string& event);

  void prune(std::string& event);
  bool pruning_by_cost() const { return cfg.s3.prune_cost > 0; }
  void reset_removal_cost() {
    removal_cost.assign(pruning_by_cost() ? size_t(g.size()) : 0, 0.0f);
    removal_frames = 0;
  }
  bool validating() const { return cfg.s3.validation_every > 0 && !in.validation.empty(); }
  // The mesh of a posed body in a camera into m: coverage and, at stage 2, triangle ids and
  // UVs; at stage 3 depth and texture colour.
  void raster_mesh_layer(const Camera& cam, const float* posed_verts, MeshCache& m) {
    const float* cut = stage == 3 && !coverage.empty() ? coverage.data() : nullptr;
    rasterize_mesh(cam, MeshView{posed_verts, body.num_verts, body.faces.data(), body.num_faces, cut}, raster);
    const int np = cam.width * cam.height;
    m.tri = raster.tri;
    m.mask = raster.mask;
    m.uv.resize(2 * size_t(np));
    interpolate(np, raster.tri.data(), raster.bary.data(), body.ft.data(), body.vt.data(), 2, m.uv.data());
    if (stage == 3) {
      m.depth = raster.depth;
      m.color.resize(3 * size_t(np));
      sample_texture(texture_view(), np, m.tri.data(), m.uv.data(), m.color.data());
      m.tri.clear();
      m.uv.clear();
    }
  }
  // Mean PSNR of the merged render over the validation views, on black.
  double validation_psnr();
  // Stage 3 starts: the validation views' poses fitted to the unfiltered avatar (s3.validation_tto).
  void fit_validation_poses(std::string& event);
  // Scores the current state for the filter's stop (host state current).
  void score_filter(int done_steps, std::string& event);
  // Stage 3 ends: the state becomes the point its validation chose.
  void finish_filtering(std::string& event);

  StepReport run_step() {
    if (stage > 3) fail("trainer", "training has finished");
    const auto t0 = std::chrono::steady_clock::now();
    StepReport r;
    r.stage = stage;
    r.steps = stage_steps(stage);
    r.event = enter_step_level();
    if (!resume_event.empty()) {  // what loading a checkpoint did (the coverage learned on resuming)
      r.event = resume_event + (r.event.empty() ? "" : "; " + r.event);
      resume_event.clear();
    }
    bool ok = true;
    if (stage == 3 && step == 0 && validating() && stop.points().empty()) {  // the unfiltered start
      sync_host();
      fit_validation_poses(r.event);
      score_filter(0, r.event);
    }
    if (r.steps > 0) {
      if (dev)
        ok = dev->step(r.loss, r.event);
      else
        ok = stage == 1 ? step1(r.loss, r.event) : stage == 2 ? step2(r.loss, r.event) : step3(r.loss, r.event);
      if (ok) {
        nan_streak = 0;
      } else {
        ++skipped;
        ++nan_streak;
        r.skipped = true;
        if (nan_streak >= cfg.nan_patience)
          fail("training", "stage " + std::to_string(stage) + " step " + std::to_string(step + 1) + ": " +
                               std::to_string(nan_streak) +
                               " steps in a row with a non-finite loss or gradient; stopping (nothing was updated "
                               "by those steps; the last checkpoint is intact)");
      }
      ++step;
    }
    r.step = step;
    seconds[size_t(stage - 1)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Advance through finished (or empty) stages.
    while (stage <= 3 && step >= stage_steps(stage)) {
      const auto t1 = std::chrono::steady_clock::now();
      sync_host();
      if (stage == 2) finish_texture(r.event);
      if (stage == 3 && validating()) finish_filtering(r.event);
      ++stage;
      step = 0;
      if (stage <= 3) {
        begin_stage(stage);
        set_level(stage, levels[size_t(stage - 1)].level_of(0));
        if (dev) dev->begin_stage(stage);
        const std::string note = level_note();
        r.event += (r.event.empty() ? "" : "; ") + std::string("begin stage ") + std::to_string(stage) +
                   (note.empty() ? "" : " (" + note + ")");
      }
      if (stage <= 3)
        seconds[size_t(stage - 1)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    }
    r.gaussians = g.size();
    return r;
  }

  // ---------------------------------------------------------------------------------
  static void put_gaussians(TrainCheckpoint& ck, const std::string& pre, const GaussianParams& x);

  TrainCheckpoint save() const;

  void load(const TrainCheckpoint& ck, const std::string& where);

  Avatar make_avatar(const GaussianParams& x) const;
};

}  // namespace haha
