#include "format/animation.h"

#include <algorithm>
#include <cmath>

#include "body/rotation.h"
#include "core/error.h"

namespace haha {

namespace {

// The key interval around t: keys i0 <= i1 and the weight of i1 (glTF's clamping outside).
void bracket(const std::vector<float>& times, double t, size_t& i0, size_t& i1, double& s) {
  const size_t K = times.size();
  if (t <= times[0] || K == 1) {
    i0 = i1 = 0, s = 0;
    return;
  }
  if (t >= times[K - 1]) {
    i0 = i1 = K - 1, s = 0;
    return;
  }
  i1 = size_t(std::upper_bound(times.begin(), times.end(), float(t)) - times.begin());
  i1 = std::min(std::max<size_t>(i1, 1), K - 1);
  i0 = i1 - 1;
  s = (t - times[i0]) / (double(times[i1]) - times[i0]);
  s = std::clamp(s, 0.0, 1.0);
}

}  // namespace

SmplxParams sample_animation(const AvatarAnimation& a, double t) {
  SmplxParams p;
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, a.duration);
  for (const AnimationTrack& tr : a.tracks) {
    size_t i0 = 0, i1 = 0;
    double s = 0;
    bracket(tr.times, t, i0, i1, s);
    if (tr.step) s = 0;
    if (tr.translation) {
      for (int c = 0; c < 3; ++c) {
        const double x = tr.values[i0 * 3 + c], y = tr.values[i1 * 3 + c];
        p.transl[size_t(c)] = float(x + s * (y - x));
      }
      continue;
    }
    const float* q0 = &tr.values[i0 * 4];
    const float* q1 = &tr.values[i1 * 4];
    const Quat<double> q = slerp_shortest({q0[0], q0[1], q0[2], q0[3]}, {q1[0], q1[1], q1[2], q1[3]}, s);
    const Vec3<double> w = quat_to_axis_angle(q);
    for (int c = 0; c < 3; ++c) p.pose[size_t(3 * tr.joint + c)] = float(w[c]);
  }
  return p;
}

double animation_rate(const AvatarAnimation& a) {
  return a.frames > 1 && a.duration > 0 ? double(a.frames - 1) / a.duration : 30.0;
}

Motion animation_motion(const AvatarAnimation& a, double fps) {
  if (fps < 0 || !std::isfinite(fps)) fail(a.name, "sampling rate must be positive");
  Motion m;
  m.source = a.name;
  m.fps = fps > 0 ? fps : animation_rate(a);
  // Frames at k / fps up to the duration; the small tolerance keeps the last key.
  const size_t n = size_t(std::floor(a.duration * m.fps + 1e-6)) + 1;
  m.frames.reserve(n);
  for (size_t k = 0; k < n; ++k) m.frames.push_back(sample_animation(a, double(k) / m.fps));
  return m;
}

size_t find_animation(const std::vector<AvatarAnimation>& list, const std::string& key, const std::string& where) {
  for (size_t i = 0; i < list.size(); ++i)
    if (list[i].name == key) return i;
  const bool digits = !key.empty() && std::all_of(key.begin(), key.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (digits && key.size() < 9 && size_t(std::stoul(key)) < list.size()) return size_t(std::stoul(key));
  std::string names;
  for (size_t i = 0; i < list.size(); ++i) names += (i ? ", " : "") + std::to_string(i) + " '" + list[i].name + "'";
  fail(where, "no animation '" + key + "' (" + (list.empty() ? std::string("the file has none") : "it has " + names) + ")");
}

}  // namespace haha
