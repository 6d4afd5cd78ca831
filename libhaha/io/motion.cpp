// AMASS motions (SMPL-X stage-ii and SMPL+H), and motion files in general.
#include "io/motion.h"

#include "core/error.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

namespace haha {

namespace {

// Frame rate under either AMASS spelling (SMPL-X: mocap_frame_rate, SMPL+H: mocap_framerate).
bool frame_rate(const Npz& z, double& fps) {
  for (const char* key : {"mocap_frame_rate", "mocap_framerate", "fps"}) {
    if (!z.has(key)) continue;
    fps = npz_scalar(z, key);
    if (!(fps > 0)) fail(z.path() + ": " + key, "frame rate must be positive");
    return true;
  }
  return false;
}

}  // namespace

Motion read_amass(const std::string& path) {
  const Npz z = Npz::read(path);
  const NpyArray& poses = z.get("poses");
  if (poses.ndim() != 2 || (poses.shape[1] != 165 && poses.shape[1] != 156))
    fail(path + ": poses", "shape " + shape_string(poses.shape) + ", expected (T, 165) SMPL-X or (T, 156) SMPL+H");
  const int64_t T = poses.shape[0], D = poses.shape[1];
  if (T < 1) fail(path + ": poses", "no frames");
  const bool smplh = D == 156;
  const std::vector<double> p = npz_numbers(z, "poses", {T, D});
  if (!z.has("trans")) fail(path + ": trans", "missing");
  const NpyArray& tr = z.get("trans");
  if (tr.ndim() != 2 || tr.shape[1] != 3)
    fail(path + ": trans", "shape " + shape_string(tr.shape) + ", expected (T, 3)");
  if (tr.shape[0] != T)
    fail(path + ": trans", std::to_string(tr.shape[0]) + " frames, poses has " + std::to_string(T));
  const std::vector<double> t = npz_numbers(z, "trans", {T, 3});
  std::vector<float> betas;
  if (!smplh && z.has("betas")) {
    const NpyArray& b = z.get("betas");
    if (b.size() > 400) fail(path + ": betas", "shape " + shape_string(b.shape) + " is too large");
    for (double v : npz_numbers(z, "betas", b.shape)) betas.push_back(float(v));
  }

  Motion m;
  m.source = path;
  if (!frame_rate(z, m.fps)) fail(path, "no frame rate (mocap_frame_rate or mocap_framerate)");
  m.frames.resize(size_t(T));
  for (int64_t f = 0; f < T; ++f) {
    SmplxParams& s = m.frames[size_t(f)];
    const double* src = p.data() + f * D;
    if (smplh) {
      // root + 21 body joints, then 2 x 15 hand joints; no jaw / eyes.
      for (int c = 0; c < 66; ++c) s.pose[size_t(c)] = float(src[c]);
      for (int c = 0; c < 90; ++c) s.pose[size_t(3 * kLeftHandFirst + c)] = float(src[66 + c]);
    } else {
      for (int c = 0; c < 165; ++c) s.pose[size_t(c)] = float(src[c]);
    }
    for (int c = 0; c < 3; ++c) s.transl[size_t(c)] = float(t[size_t(f * 3 + c)]);
    s.betas = betas;
  }
  return m;
}

Motion read_motion(const std::string& path, const BodyModel* model) {
  const Npz z = Npz::read(path);
  if (z.has("poses")) return read_amass(path);
  Motion m;
  m.source = path;
  m.frames = read_smplx_params(path, model);
  frame_rate(z, m.fps);
  return m;
}

}  // namespace haha
