// Stage 2: the texture on the frozen, refined bodies (Gaussians off).
#include "train/texture_smooth.h"
#include "train/trainer_impl.h"

namespace haha {

bool Trainer::Impl::step2(LossTerms& terms, std::string&) {
  const int B = cfg.batch;
  const LossWeights w = effective(2);
  const float inv_b = 1.0f / float(B);
  d_texture.assign(texture.size(), 0.0f);
  const TextureView tv = texture_view();
  const float black[3] = {0, 0, 0};
  for (int b = 0; b < B; ++b) {
    const int64_t k = int64_t(step) * B + b;
    const int fi = frame_of(2, k);
    MeshCache& m = mesh_of(fi);
    tex_color.resize(3 * size_t(P));
    sample_texture(tv, P, m.tri.data(), m.uv.data(), tex_color.data());
    prepare_ground_truth(fi, black);
    d_image.assign(3 * size_t(P), 0.0f);
    place_lpips_crop(2, k, fi);
    image_loss(tex_color.data(), gt.data(), H, W, in.frames[size_t(fi)].mask.data(), w, lctx, d_image.data(), inv_b,
               terms);
    sample_texture_backward(tv, P, m.tri.data(), m.uv.data(), d_image.data(), d_texture.data(), nullptr);
  }
  if (cfg.s2.smooth > 0) {  // low-evidence texels follow their neighbours (train/texture_smooth.h)
    update_texture_evidence();
    const double v = texture_smooth_loss(texture.data(), tex_smooth_w.data(), tex_size, tex_size, 3, d_texture.data(),
                                         float(cfg.s2.smooth));
    terms.total += cfg.s2.smooth * v;
  }
  if (w.tv > 0) {
    const double v = texture_tv_loss(texture.data(), tex_size, tex_size, 3, d_texture.data(), float(w.tv));
    terms.tv += v;
    terms.total += w.tv * v;
  }
  if (hook) hook(2, d_texture);
  if (!std::isfinite(terms.total) || !finite_all(d_texture)) return false;
  adam.set_lr(adam.group("texture"), texture_lr());
  adam.step(adam.group("texture"), texture.data(), d_texture.data());
  for (float& t : texture) t = std::clamp(t, 0.0f, 1.0f);
  return true;
}

}  // namespace haha
