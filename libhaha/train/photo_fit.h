// A photometric pose fit against a textured mesh, before any Gaussian exists: every
// training frame's global orient, body pose and translation and one shared RGB texture are
// optimised together so that the body, rendered with the texture (antialiased silhouette,
// render/mesh_antialias.h), matches the frames. A texture is tied to the surface and shared
// by all frames, so a misplaced limb shows as a mismatch the pose has to correct; free
// Gaussians (stage 1's pose refinement) absorb it instead.
//
// Per step one frame (seeded epochs), a random background behind both the frame (its mask)
// and the render, so coverage errors cost something on any colour; loss = mean over pixels of
// |I - gt|^2 (+ w_ssim (1 - SSIM) + w_sobel times the edge loss, train/image_loss.h), plus
// w_prior times the squared change of the pose values from their anchor (the frame's own fit,
// or its temporal average with s0.window). The first `warmup` share of the steps trains the
// texture alone (a grey texture would only pull the body onto the silhouette); the images run
// coarse to fine (s0.photo.levels), the texture with them (halved per coarser level,
// bilinearly upsampled as the images grow). Measured: docs/fit-video.md, "Photometric pose fit".
#pragma once

#include <functional>
#include <vector>

#include "body/body_model.h"
#include "train/config.h"
#include "train/trainer.h"

namespace haha {

struct PhotoFitReport {
  double loss_start = 0, loss_end = 0;  // image loss, mean over the first / last 5% of the steps
  std::vector<float> texture;           // (S, S, 3) the texture at the end, S = texture_side
  int texture_side = 0;
};

// Updates every frame's params in place (betas, hands, jaw and expression untouched).
// `progress` (optional) is called every few steps with the steps done, their count and the
// mean image loss since the last call. Throws haha::Error for frames without a mask or of
// different sizes.
PhotoFitReport fit_poses_to_images(const BodyModel& body, std::vector<TrainFrame>& frames, bool premultiplied,
                                   const Stage0Config& s0, uint64_t seed,
                                   const std::function<void(int done, int total, double loss)>& progress = {});

}  // namespace haha
