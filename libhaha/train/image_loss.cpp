#include "train/image_loss.h"

namespace haha {

void LossTerms::add(const LossTerms& o, double s) {
  total += s * o.total;
  l2 += s * o.l2;
  ssim += s * o.ssim;
  sobel += s * o.sobel;
  lpips += s * o.lpips;
  knn += s * o.knn;
  dice += s * o.dice;
  tv += s * o.tv;
  opacity += s * o.opacity;
}

double image_loss(const float* render, const float* gt, int H, int W, const float* weights, const LossWeights& w,
                  ImageLossContext& ctx, float* grad, float scale, LossTerms& terms) {
  double total = 0;
  if (w.l2 > 0) {
    const double v = l2_loss(render, gt, H, W, weights, grad, float(w.l2 * scale));
    terms.l2 += scale * v;
    total += w.l2 * v;
  }
  if (w.ssim > 0) {
    const double v = ssim_loss(render, gt, H, W, ctx.scratch, weights, grad, float(w.ssim * scale));
    terms.ssim += scale * v;
    total += w.ssim * v;
  }
  if (w.sobel > 0) {
    const double v = edge_loss(render, gt, H, W, ctx.scratch, weights, grad, float(w.sobel * scale));
    terms.sobel += scale * v;
    total += w.sobel * v;
  }
  if (w.lpips > 0 && ctx.lpips) {
    const double v = ctx.lpips->distance(render, gt, H, W, grad, float(w.lpips * scale));
    terms.lpips += scale * v;
    total += w.lpips * v;
  }
  terms.total += scale * total;
  return scale * total;
}

void composite_ground_truth(const float* rgb, const float* mask, int num_pixels, bool premultiplied,
                            const float bg[3], float* out) {
  for (int p = 0; p < num_pixels; ++p) {
    const float m = mask[p];
    for (int c = 0; c < 3; ++c) {
      const float v = rgb[3 * p + c];
      out[3 * p + c] = (premultiplied ? v : m * v) + (1.0f - m) * bg[c];
    }
  }
}

}  // namespace haha
