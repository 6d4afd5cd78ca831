#include "train/image_loss.h"

#include <algorithm>
#include <cstddef>

namespace haha {

void LossTerms::add(const LossTerms& o, double s) {
  total += s * o.total;
  l2 += s * o.l2;
  ssim += s * o.ssim;
  sobel += s * o.sobel;
  lpips += s * o.lpips;
  knn += s * o.knn;
  stretch += s * o.stretch;
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
    const PixelWindow& c = ctx.lpips_window;
    double v;
    if (c.w <= 0 || (c.w == W && c.h == H)) {
      v = ctx.lpips->distance(render, gt, H, W, grad, float(w.lpips * scale));
    } else {
      const size_t n = 3 * size_t(c.w) * size_t(c.h);
      ctx.crop_render.resize(n);
      ctx.crop_gt.resize(n);
      for (int y = 0; y < c.h; ++y) {
        const size_t src = 3 * ((size_t(c.y0) + size_t(y)) * size_t(W) + size_t(c.x0)), dst = 3 * size_t(y) * size_t(c.w);
        std::copy_n(render + src, 3 * size_t(c.w), ctx.crop_render.begin() + ptrdiff_t(dst));
        std::copy_n(gt + src, 3 * size_t(c.w), ctx.crop_gt.begin() + ptrdiff_t(dst));
      }
      ctx.crop_grad.assign(grad ? n : 0, 0.0f);
      v = ctx.lpips->distance(ctx.crop_render.data(), ctx.crop_gt.data(), c.h, c.w, grad ? ctx.crop_grad.data() : nullptr,
                              float(w.lpips * scale));
      if (grad)
        for (int y = 0; y < c.h; ++y) {
          float* g = grad + 3 * ((size_t(c.y0) + size_t(y)) * size_t(W) + size_t(c.x0));
          const float* s = ctx.crop_grad.data() + 3 * size_t(y) * size_t(c.w);
          for (size_t i = 0; i < 3 * size_t(c.w); ++i) g[i] += s[i];
        }
    }
    terms.lpips += scale * v;
    total += w.lpips * v;
  }
  terms.total += scale * total;
  return scale * total;
}

PixelWindow person_crop(const float* mask, int H, int W, int side, double u, double v) {
  PixelWindow all{0, 0, W, H};
  if (side <= 0 || !mask) return all;
  int x_lo = W, x_hi = -1, y_lo = H, y_hi = -1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (mask[size_t(y) * size_t(W) + size_t(x)] > 0.5f) {
        x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x);
        y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y);
      }
  if (x_hi < 0) return all;
  const int s_w = std::min(side, W), s_h = std::min(side, H);
  const int cx = x_lo + int(u * double(x_hi - x_lo + 1)), cy = y_lo + int(v * double(y_hi - y_lo + 1));
  PixelWindow c;
  c.w = s_w, c.h = s_h;
  c.x0 = std::clamp(cx - s_w / 2, 0, W - s_w);
  c.y0 = std::clamp(cy - s_h / 2, 0, H - s_h);
  return c;
}

void composite_ground_truth(const float* rgb, const float* mask, int num_pixels, bool premultiplied,
                            const float bg[3], float* out) {
  for (int p = 0; p < num_pixels; ++p) composite_ground_truth_pixel(rgb, mask, p, premultiplied, bg, out);
}

}  // namespace haha
