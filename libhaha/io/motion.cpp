// AMASS motions (SMPL-X stage-ii and SMPL+H), and motion files in general.
#include "io/motion.h"

#include <algorithm>
#include <cmath>

#include "body/rotation.h"
#include "core/error.h"
#include "core/text.h"
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

// Optional `up` (3,) of the file's world; AMASS's default is +Z.
std::array<double, 3> world_up(const Npz& z, std::array<double, 3> fallback) {
  if (!z.has("up")) return fallback;
  const std::vector<double> u = npz_numbers(z, "up", {3});
  const double n = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  if (!(n > 1e-6)) fail(z.path() + ": up", "must be a non-zero direction");
  return {u[0] / n, u[1] / n, u[2] / n};
}

std::string gender_of(const Npz& z) {
  if (!z.has_text("gender")) return {};
  const std::string g = ascii_lower(z.text("gender"));
  if (g != "male" && g != "female" && g != "neutral") fail(z.path() + ": gender", "'" + g + "' is not male, female or neutral");
  return g;
}

using V3 = Vec3<double>;

std::vector<float> lerp(const std::vector<float>& a, const std::vector<float>& b, double s) {
  std::vector<float> out(std::max(a.size(), b.size()), 0.0f);
  for (size_t i = 0; i < out.size(); ++i) {
    const double x = i < a.size() ? a[i] : 0.0, y = i < b.size() ? b[i] : 0.0;
    out[i] = float(x + s * (y - x));
  }
  return out;
}

}  // namespace

Quat<double> slerp_shortest(Quat<double> a, Quat<double> b, double s) {
  double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
  if (d < 0) b = {-b.w, -b.x, -b.y, -b.z}, d = -d;
  double wa = 1 - s, wb = s;
  if (d < 0.9995) {  // else nearly equal: linear + normalise is exact to ~1e-7
    const double th = std::acos(std::min(d, 1.0)), sn = std::sin(th);
    wa = std::sin((1 - s) * th) / sn;
    wb = std::sin(s * th) / sn;
  }
  Quat<double> q{wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z};
  const double n = std::sqrt(qnorm2(q));
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

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
  m.pose_width = int(D);
  m.up = world_up(z, {0, 0, 1});
  m.gender = gender_of(z);
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
  m.up = world_up(z, {0, 1, 0});
  m.gender = gender_of(z);
  frame_rate(z, m.fps);
  return m;
}

void motion_to_y_up(Motion& m, const std::array<double, 3>& rest_pelvis) {
  const V3 up(m.up[0], m.up[1], m.up[2]), y(0, 1, 0);
  const V3 axis = cross(up, y);
  const double s = norm(axis), c = dot(up, y);
  if (s < 1e-12 && c > 0) return;
  // Smallest rotation up -> +Y; for up = -Y any half turn about a horizontal axis does.
  const V3 w = s < 1e-12 ? V3(M_PI, 0, 0) : (std::atan2(s, c) / s) * axis;
  const Mat3<double> R = rodrigues(w);
  const V3 J0(rest_pelvis[0], rest_pelvis[1], rest_pelvis[2]);
  for (SmplxParams& f : m.frames) {
    const V3 root(f.pose[0], f.pose[1], f.pose[2]);
    const V3 r = matrix_to_axis_angle(R * rodrigues(root));
    const V3 t = R * (J0 + V3(f.transl[0], f.transl[1], f.transl[2])) - J0;
    for (int k = 0; k < 3; ++k) f.pose[size_t(k)] = float(r[k]), f.transl[size_t(k)] = float(t[k]);
  }
  m.up = {0, 1, 0};
}

Motion resample_motion(const Motion& m, double fps) {
  if (!(fps > 0) || !std::isfinite(fps)) fail(m.source, "resample rate must be positive");
  if (m.frames.empty()) fail(m.source, "no frames to resample");
  Motion out = m;
  out.fps = fps;
  const double duration = double(m.frames.size() - 1) / m.fps;
  // The small tolerance keeps the last frame when the duration is an exact multiple.
  const size_t n = size_t(std::floor(duration * fps + 1e-9)) + 1;
  out.frames.assign(n, SmplxParams{});
  for (size_t k = 0; k < n; ++k) {
    const double src = std::min(double(k) / fps * m.fps, double(m.frames.size() - 1));
    const size_t i0 = size_t(std::floor(src)), i1 = std::min(i0 + 1, m.frames.size() - 1);
    const double s = src - double(i0);
    const SmplxParams &a = m.frames[i0], &b = m.frames[i1];
    SmplxParams& f = out.frames[k];
    for (int j = 0; j < kNumJoints; ++j) {
      const V3 wa(a.pose[size_t(3 * j)], a.pose[size_t(3 * j + 1)], a.pose[size_t(3 * j + 2)]);
      const V3 wb(b.pose[size_t(3 * j)], b.pose[size_t(3 * j + 1)], b.pose[size_t(3 * j + 2)]);
      const V3 w = quat_to_axis_angle(slerp_shortest(axis_angle_to_quat(wa), axis_angle_to_quat(wb), s));
      for (int c = 0; c < 3; ++c) f.pose[size_t(3 * j + c)] = float(w[c]);
    }
    for (int c = 0; c < 3; ++c) f.transl[size_t(c)] = float(a.transl[size_t(c)] + s * (b.transl[size_t(c)] - a.transl[size_t(c)]));
    f.betas = lerp(a.betas, b.betas, s);
    f.expression = lerp(a.expression, b.expression, s);
  }
  return out;
}

}  // namespace haha
