#include "app/pack_run.h"

#include <cmath>
#include <filesystem>

#include "app/run_dir.h"
#include "core/error.h"
#include "format/avatar_npz.h"
#include "io/body_model_io.h"
#include "io/motion.h"

namespace haha {

namespace {

// The motions as named animations; native parameter files resolve PCA hands with `body`.
std::vector<AnimationSource> animation_sources(const PackAnimations& p, const BodyModel& body) {
  if (p.names.size() > p.files.size()) fail("--animation-name", "more names than --animation files");
  if (p.rate < 0 || !std::isfinite(p.rate) || p.rate > 1000) fail("--animation-rate", "must be in (0, 1000] frames per second");
  if (!(p.tolerance >= 0) || !std::isfinite(p.tolerance)) fail("--animation-tolerance", "must be a non-negative number of radians");
  std::vector<AnimationSource> out;
  for (size_t i = 0; i < p.files.size(); ++i) {
    AnimationSource s;
    s.name = i < p.names.size() ? p.names[i] : std::filesystem::path(p.files[i]).stem().string();
    s.motion = read_motion(p.files[i], &body);
    if (p.rate > 0) s.motion = resample_motion(s.motion, p.rate);
    s.tolerance = p.tolerance;
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

PackedSizes pack_run(const std::string& run_or_npz, const std::string& model, const std::string& out,
                     const PackOptions& pack_options, const PackAnimations& animations) {
  namespace fs = std::filesystem;
  Avatar avatar;
  if (fs::is_regular_file(run_or_npz)) {
    if (model.empty()) fail(run_or_npz, "an avatar.npz given directly needs --model (the body model it was trained on)");
    avatar = load_avatar_npz(run_or_npz);
    attach_body(avatar, load_body_model(model), run_or_npz);
  } else {
    avatar = load_run_avatar(RunDir(run_or_npz), model);
  }
  PackOptions options = pack_options;
  if (!animations.files.empty()) options.animations = animation_sources(animations, avatar.body);
  return write_avatar_glb(avatar, out, options);
}

}  // namespace haha
