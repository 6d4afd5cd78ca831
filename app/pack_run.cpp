#include "app/pack_run.h"

#include <filesystem>

#include "app/run_dir.h"
#include "core/error.h"
#include "format/avatar_npz.h"
#include "io/body_model_io.h"

namespace haha {

PackedSizes pack_run(const std::string& run_or_npz, const std::string& model, const std::string& out,
                     const PackOptions& options) {
  namespace fs = std::filesystem;
  Avatar avatar;
  if (fs::is_regular_file(run_or_npz)) {
    if (model.empty()) fail(run_or_npz, "an avatar.npz given directly needs --model (the body model it was trained on)");
    avatar = load_avatar_npz(run_or_npz);
    attach_body(avatar, load_body_model(model), run_or_npz);
  } else {
    avatar = load_run_avatar(RunDir(run_or_npz), model);
  }
  return write_avatar_glb(avatar, out, options);
}

}  // namespace haha
