// Evaluation of trained avatars on held-out frames (docs/method.md section 4): test-time pose
// optimisation with the avatar frozen, then PSNR / SSIM (/ LPIPS-Alex) over full frames on
// a fixed background, PSNR over the person's pixels and in a band around the person's
// outline (train/outline_band.h), Gaussian counts, storage and render time, for the paper's stage
// table: textured mesh only / full Gaussians / naive merge / HAHA filtered. No file I/O
// (the data layer writes the report and the contact sheet).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "train/lpips.h"
#include "train/trainer.h"

namespace haha {

// One row of the stage table: which layers of which avatar are rendered.
struct EvalVariant {
  std::string name;              // "mesh only", "full Gaussians", ...
  const Avatar* avatar = nullptr;
  bool mesh = true;              // textured mesh layer
  bool gaussians = true;         // Gaussian layer (occluded by the mesh when both)
};

// The paper's stage table, in its order: mesh only (the final avatar's texture), full
// Gaussians (stage 1), naive merge (stage 1's Gaussians over the texture: stages 1 + 2),
// HAHA filtered (all three stages). Both avatars must outlive the list.
std::vector<EvalVariant> paper_variants(const Avatar& filtered, const Avatar& stage1);
// Short names of paper_variants()'s rows, for choosing some: mesh, full, naive, haha.
inline constexpr const char* kPaperVariantKeys[] = {"mesh", "full", "naive", "haha"};

// Training time attributed to paper_variants()[variant_index] as in the paper's table, from
// the wall time of each stage: mesh only = stage 2, full Gaussians = stage 1, naive merge =
// stages 1 + 2, HAHA = all three.
double variant_train_seconds(const std::array<double, 3>& stage_seconds, size_t variant_index);

struct EvalOptions {
  int tto_steps = 100;             // test-time pose optimisation steps (0 = off)
  int tto_resolution = 0;          // > 0: 3/4 of the steps on the frame downscaled to this longer side, then the rest at full size
  double lr_pose = 3e-3;           // global orient, body pose, transl
  double lr_pose_fine = 3e-4;      // jaw, hands
  double tto_w_ssim = 0.1, tto_w_dice = 0.1;  // TTO loss: L2 + w (1 - SSIM) + w Dice
  float background[3] = {0, 0, 0};
  bool premultiplied = false;      // see TrainInput
  LpipsNet<float>* lpips = nullptr;  // AlexNet LPIPS metric; null = unavailable
  int keep_images = 0;             // frames (from the first) whose layers are kept for pictures
  // Antialiased mesh silhouette (render/mesh_antialias.h) in test-time pose optimisation and
  // the final render: partial coverage at the mesh's edges, and a silhouette gradient to the
  // pose.
  bool antialias = false;
  // Fixed poses, one per frame (another variant's VariantEval::poses): no test-time pose
  // optimisation, every variant scored at the same pose. Null: each variant fits its own.
  const std::vector<SmplxParams>* poses = nullptr;
  // Diagnostics of a learned mesh coverage (the mesh may fade where it overshoots the person):
  //   pixel: the mesh layer's coverage multiplied by each frame's true matte, its depth test
  //          only where the matte is at least half: the mesh knows the outline in every frame,
  //          the ceiling of any coverage;
  //   texel: a 0/1 coverage per texel, 0 where the pixels a texel drew in the mesh-only
  //          variant were mostly outside the matte (VariantEval::texel_coverage, passed here
  //          as `texel_coverage` for the merges): the ceiling of a coverage the texture can
  //          carry (a glTF MASK alpha), fitted to the scored frames themselves.
  enum class CoverageOracle { none, pixel, texel };
  CoverageOracle coverage_oracle = CoverageOracle::none;
  const std::vector<float>* texel_coverage = nullptr;  // (Ht * Wt) 0/1; texel mode's merges
};

// A run's own test-time settings (eval.*: steps, coarse size, rates, antialiasing); the rest
// as EvalOptions' defaults.
EvalOptions eval_options_of(const TrainConfig& c);

// Pixels within this distance of the ground-truth mask's outline make the outline PSNR.
constexpr int kOutlineBandPx = 3;

struct FrameEval {
  double psnr = 0, ssim = 0, lpips = -1;  // lpips < 0: unavailable
  double psnr_outline = 0;                // PSNR within kOutlineBandPx of the person's outline
  double psnr_person = 0;                 // PSNR over the person's pixels: ground-truth mask > 0.5 (NaN: none)
  double psnr_part = std::nan("");        // PSNR weighted by TrainFrame::part (NaN: none, or empty)
  // Mean transmittance of the render (1 - A)(1 - mesh coverage) weighted by the part: the
  // daylight through it (a garment between the legs; NaN: no part)
  double transmittance_part = std::nan("");
  double render_ms = 0;                   // LBS + render of the final pose
  double tto_loss_start = 0, tto_loss_end = 0;
  // Kept for the first keep_images frames: (H, W, 3) images.
  std::vector<float> image, gaussian_layer, mesh_layer, ground_truth;
};

struct VariantEval {
  std::string name;
  size_t paper_row = 0;  // its index in paper_variants() (its training time, the checks)
  bool mesh = false, gaussians = false;
  int num_gaussians = 0;
  int64_t storage_bytes = 0;
  double psnr = 0, ssim = 0, lpips = -1, render_ms = 0;  // means over frames
  double psnr_outline = 0;  // mean over the frames that have an outline (NaN: none has)
  double psnr_person = 0;   // mean over the frames that have person pixels (NaN: none has)
  double psnr_part = 0;     // mean over the frames whose part has pixels (NaN: none has)
  double transmittance_part = 0;  // the same frames' mean transmittance over the part
  std::vector<FrameEval> frames;
  std::vector<SmplxParams> poses;  // the pose each frame was scored at (after its optimisation)
  std::vector<float> texel_coverage;  // CoverageOracle::texel, mesh-only variant: (Ht * Wt) 0/1
};

// Bytes to store the variant: 56 per Gaussian (14 float32 values, as the paper counts)
// plus 4 for its face index, plus the texture as 8-bit RGB when the mesh is used.
int64_t storage_bytes(const Avatar& a, bool mesh, bool gaussians);

// Evaluates one variant on the frames (their params are the initial poses). Throws
// haha::Error for an avatar without a body, texture (mesh variants) or frames of
// different sizes.
VariantEval evaluate_variant(const EvalVariant& v, const std::vector<TrainFrame>& frames, const EvalOptions& opt);

// Body regions by the dominant skinning joint of each face (sum of its corners' weights).
enum class BodyRegion { head, torso, arms, hands, legs, feet, count };
const char* region_name(BodyRegion r);
BodyRegion joint_region(int joint);
std::vector<BodyRegion> face_regions(const BodyModel& body);
// Gaussians per region (index = BodyRegion) of a set bound to `body`.
std::vector<int> gaussians_per_region(const BodyModel& body, const BoundGaussians& g);

}  // namespace haha
