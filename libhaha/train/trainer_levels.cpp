// Coarse to fine: which level of the image pyramid a step trains at, and the switch from one
// level to the next (frames, image-sized caches, the texture of stage 2).
#include "train/trainer_impl.h"

namespace haha {

void Trainer::Impl::setup_levels() {
  const char* keys[3] = {"s1.levels", "s2.levels", "s3.levels"};
  const std::string* texts[3] = {&cfg.s1.levels, &cfg.s2.levels, &cfg.s3.levels};
  bool any = false;
  for (int s = 0; s < 3; ++s) {
    levels[size_t(s)] = make_level_schedule(*texts[s], stage_steps(s + 1), keys[s]);
    const int L = levels[size_t(s)].num_levels();
    any = any || L > 1;
    const int shorter = level_side(std::min(W, H), 0, L);
    if (L > 1 && shorter < 8)
      fail("config", std::string(keys[s]) + ": " + std::to_string(L) + " levels make the coarsest images " +
                         std::to_string(shorter) + " px on their shorter side, too small (at least 8: fewer levels, "
                         "or a larger resolution)");
  }
  if (texture_side(0) < 4)
    fail("config", "s2.levels: the coarsest texture would be " + std::to_string(texture_side(0)) +
                       " texels (fewer levels, or a larger s2.texture_size)");
  full_frames.clear();
  if (any) full_frames = in.frames;
  level_stage = 0;
  level = -1;
}

int Trainer::Impl::texture_side(int s2_level) const {
  return level_side(cfg.s2.texture_size, s2_level, levels[1].num_levels());
}

void Trainer::Impl::set_level(int s, int lvl) {
  if (s > 3) return;
  const LevelSchedule& sched = levels[size_t(s - 1)];
  if (!full_frames.empty()) {
    const int full = std::max(full_frames[0].camera.width, full_frames[0].camera.height);
    const int side = level_side(full, lvl, sched.num_levels());
    if (side != std::max(W, H)) {
      for (int i = 0; i < nf; ++i) in.frames[size_t(i)] = downscale_train_frame(full_frames[size_t(i)], side);
      W = in.frames[0].camera.width;
      H = in.frames[0].camera.height;
      P = W * H;
      lctx.lpips = lpips && std::min(W, H) >= lpips->min_size() ? lpips.get() : nullptr;
      if (s >= 2) reset_mesh_cache();
    }
  }
  if (s == 2 && !texture.empty() && texture_side(lvl) != tex_size) {
    // The texture grows with the images: bilinear upsampling keeps what it learnt, each new
    // texel starting from the Adam moments of the texel it lies in.
    const int ns = texture_side(lvl);
    texture = resample_texture(texture, tex_size, ns);
    std::vector<int64_t> parent(size_t(ns) * ns);
    for (int j = 0; j < ns; ++j)
      for (int i = 0; i < ns; ++i)
        parent[size_t(j) * ns + i] = int64_t(j * tex_size / ns) * tex_size + i * tex_size / ns;
    adam.reindex(adam.group("texture"), parent);
    tex_size = ns;
  }
  level_stage = s;
  level = lvl;
}

std::string Trainer::Impl::enter_step_level() {
  const int want = levels[size_t(stage - 1)].level_of(step);
  if (level_stage == stage && level == want) return "";
  sync_host();
  const int side_before = std::max(W, H);
  set_level(stage, want);
  if (dev) dev->begin_stage(stage);
  return std::max(W, H) == side_before ? "" : level_note();
}

std::string Trainer::Impl::level_note() const {
  const int L = levels[size_t(level_stage - 1)].num_levels();
  if (L <= 1) return "";
  std::string e = "level " + std::to_string(level + 1) + "/" + std::to_string(L) + ": " + std::to_string(W) + "x" +
                  std::to_string(H) + " px";
  if (level_stage == 2) e += ", texture " + std::to_string(tex_size) + "^2";
  return e;
}

}  // namespace haha
