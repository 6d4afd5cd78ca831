// The HAHA trainer: the three stages of the paper on in-memory data (no file I/O here;
// the data layer reads datasets, writes checkpoints and the run directory).
//
//   stage 1  Gaussians bound to faces (one per face at start) + per-frame SMPL-X pose /
//            transl and shared betas, refined through LBS -> face frames -> posed Gaussians
//            -> Gaussian raster. Opacity fixed (config s1.opacity), random background,
//            no mesh occlusion (D = inf). Loss L2 + SSIM + edge + KNN + Dice(A, mask)
//            (+ LPIPS). Face-bound densification (clone / split, children keep the face),
//            log-linear position learning rate.
//   stage 2  texture only, through the mesh rasterizer with the refined (frozen) poses,
//            masked to the person. Loss L2 + SSIM + TV (+ LPIPS).
//   stage 3  merged render (mesh -> D, M, m; Gaussians occluded where centre z > D; I =
//            C_front + (1 - A)(m M + (1 - m) B)), opacity and colour only. Loss = stage-1
//            image loss + KNN + opacity regulariser + Dice(S_gt, 1 - (1 - m)(1 - A));
//            Gaussians with opacity below s3.prune_threshold are deleted every
//            s3.prune_every steps and at the end.
//
// Every random choice (frame order, background colours, split offsets) is a counter-based
// function of (seed, stage, step), and every sum is taken in a fixed order, so a run
// restored from a checkpoint repeats the uninterrupted run exactly.
//
// Non-finite guard: a step whose loss or gradients are not all finite changes nothing
// (it is counted and reported); config nan_patience such steps in a row stop the run with
// a haha::Error.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "body/smplx_params.h"
#include "core/camera.h"
#include "core/device.h"
#include "train/config.h"
#include "train/filter_stop.h"
#include "train/image_loss.h"
#include "train/lpips.h"

namespace haha {

// One training frame in memory (the training split only).
struct TrainFrame {
  std::string name;  // named in errors (the image file)
  Camera camera;     // width/height = the image's
  SmplxParams params;  // initial fit
  std::vector<float> rgb;   // (H, W, 3) in [0, 1]
  std::vector<float> mask;  // (H, W) in [0, 1], 1 = person
  // Optional (H, W) in [0, 1]: a part of the person scored on its own by evaluation
  // (FrameEval::psnr_part, e.g. a garment's pixels); empty: none. Training ignores it.
  std::vector<float> part;
};

struct TrainInput {
  const BodyModel* body = nullptr;  // must outlive the trainer; needs vt / ft
  std::vector<TrainFrame> frames;
  // Held out of every stage: where stage 3's filtering stops (s3.validation_every,
  // train/filter_stop.h). Same size as `frames`; empty: the fixed weight's result.
  std::vector<TrainFrame> validation;
  bool premultiplied = false;  // rgb already composited on black with the soft mask
  const LpipsWeights* lpips = nullptr;  // VGG part used for the LPIPS loss when given
};

// Checks everything the trainer relies on before any work: body (faces, UVs), at least one
// frame, equal image sizes, buffer sizes, finite pixels and parameters, sane cameras.
// Throws haha::Error "<frame name>: <problem>".
void validate_train_input(const TrainInput& in);

// The video's one shape: the mean of the frames' fitted betas, at most the model's shape
// columns (min(10, num_shape) zeros when no frame has any). The trainer and the photometric
// pose fit share it.
std::vector<float> video_betas(const std::vector<TrainFrame>& frames, int num_shape);

// Trainer state for a checkpoint: named 1-D arrays (the data layer stores them as npz).
struct TrainCheckpoint {
  std::map<std::string, std::vector<float>> f32;
  std::map<std::string, std::vector<int32_t>> i32;
  std::map<std::string, std::vector<double>> f64;
};

struct StepReport {
  int stage = 0;       // of the step just run
  int step = 0;        // completed steps of that stage
  int steps = 0;       // steps of that stage
  LossTerms loss;      // batch mean
  int gaussians = 0;   // after the step
  bool skipped = false;  // non-finite: nothing was updated
  std::string event;   // "densify ...", "prune ...", "stage 2" ...
};

class Trainer {
 public:
  // Validates the input (validate_train_input + validate_config) and sets up stage 1.
  // Where the steps run: Device::cuda runs every stage's step on the GPU
  // (train/trainer_cuda.cpp), the state copied to the host at densification / pruning
  // steps, stage changes, checkpoints and for the outputs; the results follow the CPU's
  // within floating-point reordering. Device::cuda throws haha::Error "cuda: no usable GPU: <why>" without a usable
  // device, "cuda: ..." for what the GPU path does not support (the LPIPS loss) or a
  // build without the CUDA backend.
  Trainer(const TrainConfig& config, TrainInput input, Device device = Device::cpu);
  ~Trainer();
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  int stage() const;          // 1, 2, 3; 4 = finished
  int step_in_stage() const;  // completed steps of the current stage
  int64_t completed_steps() const;  // over all stages
  bool done() const;
  StepReport step();          // one optimisation step (advances the stage when it ends)
  int num_gaussians() const;
  const TrainConfig& config() const;
  Device device() const;

  TrainCheckpoint save() const;
  // Restores a save() of a run with the same config and input. Throws haha::Error
  // "<where>: <key>: <problem>" for a missing / inconsistent array.
  void load(const TrainCheckpoint& ck, const std::string& where);

  // The current avatar (values activated). Stage 3 done: the filtered HAHA avatar.
  Avatar avatar() const;
  // The Gaussians as they were at the end of stage 1 (the "full Gaussian" avatar) with the
  // current texture. Throws haha::Error before stage 1 has finished.
  Avatar stage1_avatar() const;
  bool has_stage1() const;
  std::vector<SmplxParams> refined_params() const;  // per training frame, with the shared betas
  std::vector<SmplxParams> validation_params() const;  // per validation frame, with the shared betas
  // Stage 1: per Gaussian, the densification statistic since the last densification (mean
  // over the views that saw it of |dL/d(screen centre)| in NDC units; 0 where unseen).
  std::vector<float> densify_statistic() const;
  // (S, S) how much the training frames saw each texel of the current texture, in frontal
  // pixels (train/texture_evidence.h); empty before stage 2.
  std::vector<float> texture_evidence() const;
  std::array<double, 3> stage_seconds() const;      // wall time spent in each stage
  // Stage 3 with validation views: the points its filtering was scored at and the index of
  // the one it ended on (-1: no validation, or not scored yet).
  std::vector<FilterStopPoint> filter_points() const;
  int filter_choice() const;
  int64_t skipped_steps() const;
  // Whether the LPIPS-VGG loss term is in use (weights given, with a VGG part, and images
  // at least the network's minimum size).
  bool lpips_active() const;

  // Test hook: called before each optimiser update with the stage and its first gradient
  // buffer (offsets / texture / opacity logits), which it may alter.
  void set_gradient_hook(std::function<void(int stage, std::vector<float>& grad)> hook);
  // Test hook: called in stage 1 with pose refinement with each pose-refinement gradient
  // as the optimiser receives it, by its group name ("betas", "frame<i>.body",
  // "frame<i>.fine" for the frames the batch drew).
  void set_pose_gradient_hook(std::function<void(const std::string& group, const std::vector<float>& grad)> hook);

 private:
  struct Impl;
  std::unique_ptr<Impl> p_;
};

}  // namespace haha
