// The weighted image loss of the HAHA stages (docs/method.md section 3):
//   w.l2 L2 + w.ssim (1 - SSIM) + w.sobel Edge + w.lpips LPIPS-VGG
// of a render against the ground truth, value and gradient together, plus the small
// helpers the stages share (ground truth over a background, the silhouette union).
#pragma once

#include <cstdint>
#include <vector>

#include "core/hd.h"
#include "train/config.h"
#include "train/losses.h"
#include "train/lpips.h"

namespace haha {

// Loss values of one step (averaged over the batch); unused terms stay 0.
struct LossTerms {
  double total = 0, l2 = 0, ssim = 0, sobel = 0, lpips = 0, knn = 0, dice = 0, tv = 0, opacity = 0, stretch = 0;
  void add(const LossTerms& o, double s);
};

// A rectangle of pixels; w == 0 means the whole image.
struct PixelWindow {
  int x0 = 0, y0 = 0, w = 0, h = 0;
};

// The LPIPS crop (the authors train LPIPS-VGG on 256 x 256 crops of the person, not full
// frames): a square of side min(side, W, H) centred at the point (u, v) in [0, 1)^2 of the
// bounding box of mask > 0.5, shifted into the image. An empty mask or side <= 0 gives the
// whole image.
PixelWindow person_crop(const float* mask, int H, int W, int side, double u, double v);

struct ImageLossContext {
  LossScratch<float> scratch;
  LpipsNet<float>* lpips = nullptr;  // null: the LPIPS term is off
  PixelWindow lpips_window;          // where LPIPS looks (default: the whole image)
  std::vector<float> crop_render, crop_gt, crop_grad;
};

// Adds scale * d(weighted loss)/d(render) into grad (may be null) and the weighted terms
// (times scale) into `terms`; returns the weighted sum (times scale). `weights` (H, W) is
// an optional pixel mask for L2 / SSIM / edge; LPIPS sees ctx.lpips_window unmasked.
double image_loss(const float* render, const float* gt, int H, int W, const float* weights, const LossWeights& w,
                  ImageLossContext& ctx, float* grad, float scale, LossTerms& terms);

// Ground truth over a background colour: premultiplied images (already on black, soft
// mask) give rgb + (1 - mask) bg; others mask * rgb + (1 - mask) bg. out (P, 3).
void composite_ground_truth(const float* rgb, const float* mask, int num_pixels, bool premultiplied,
                            const float bg[3], float* out);
// One pixel of it (the CUDA trainer's kernel runs the same).
HAHA_HD void composite_ground_truth_pixel(const float* rgb, const float* mask, int64_t p, bool premultiplied,
                                          const float* bg, float* out) {
  const float m = mask[p];
  for (int c = 0; c < 3; ++c) {
    const float v = rgb[3 * p + c];
    out[3 * p + c] = (premultiplied ? v : m * v) + (1.0f - m) * bg[c];
  }
}

// Soft silhouette union of the mesh mask m and the Gaussian alpha A:
// S = 1 - (1 - m)(1 - A) (so A receives gradient wherever the mesh does not cover).
// Either input may be null (= 0). T = float or double.
template <class T>
HAHA_HD T silhouette_union_value(T m, T a) {
  return T(1) - (T(1) - m) * (T(1) - a);
}
template <class T>
void silhouette_union(const T* mesh_mask, const T* alpha, int num_pixels, T* out) {
  for (int p = 0; p < num_pixels; ++p)
    out[p] = silhouette_union_value(mesh_mask ? mesh_mask[p] : T(0), alpha ? alpha[p] : T(0));
}
// dL/dA from dL/dS: (1 - m) dL/dS. out is OVERWRITTEN.
template <class T>
HAHA_HD T silhouette_union_grad(T m, T d_union) {
  return (T(1) - m) * d_union;
}
template <class T>
void silhouette_union_backward(const T* mesh_mask, const T* d_union, int num_pixels, T* d_alpha) {
  for (int p = 0; p < num_pixels; ++p) d_alpha[p] = silhouette_union_grad(mesh_mask ? mesh_mask[p] : T(0), d_union[p]);
}

}  // namespace haha
