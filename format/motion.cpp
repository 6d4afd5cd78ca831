#include "format/motion.h"

#include <cmath>

#include "core/error.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

namespace haha {

Motion read_motion(const std::string& path) {
  Motion m;
  const Npz z = Npz::read(path);
  if (!z.has("poses")) {
    m.frames = read_smplx_params(path);
    return m;
  }
  const NpyArray& poses = z.get("poses", {-1, -1});
  const int64_t T = poses.shape[0], D = poses.shape[1];
  if (D != 165 && D != 156) fail(path, "poses: " + std::to_string(D) + " values per frame, expected 165 (SMPL-X) or 156 (SMPL+H)");
  const std::vector<float> p = poses.as_float();
  std::vector<float> trans(size_t(T) * 3, 0.0f);
  if (z.has("trans")) trans = z.get("trans", {T, 3}).as_float();
  for (const char* key : {"mocap_frame_rate", "mocap_framerate"}) {
    if (!z.has(key)) continue;
    const std::vector<double> r = z.get(key).as_double();
    if (r.size() == 1 && std::isfinite(r[0]) && r[0] > 0) m.fps = r[0];
    break;
  }
  m.frames.resize(size_t(T));
  for (int64_t t = 0; t < T; ++t) {
    SmplxParams& f = m.frames[size_t(t)];
    const float* src = &p[size_t(t * D)];
    if (D == 165) {
      for (int k = 0; k < 165; ++k) f.pose[size_t(k)] = src[k];
    } else {
      for (int k = 0; k < 66; ++k) f.pose[size_t(k)] = src[k];                               // global + 21 body
      for (int k = 0; k < 90; ++k) f.pose[size_t(3 * kLeftHandFirst + k)] = src[66 + k];     // both hands
    }
    for (int k = 0; k < 3; ++k) f.transl[size_t(k)] = trans[size_t(t * 3 + k)];
    for (float v : f.pose)
      if (!std::isfinite(v)) fail(path, "poses: non-finite value in frame " + std::to_string(t));
    for (float v : f.transl)
      if (!std::isfinite(v)) fail(path, "trans: non-finite value in frame " + std::to_string(t));
  }
  return m;
}

}  // namespace haha
