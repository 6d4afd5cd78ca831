#include "app/one_euro.h"

#include <cmath>

#include "body/rotation.h"
#include "io/motion.h"

namespace haha {

namespace {

double alpha(double cutoff_hz, double fps) {
  const double tau = 1.0 / (2 * M_PI * cutoff_hz);
  return 1.0 / (1.0 + tau * fps);
}

// One causal pass over any signal with a difference (tangent step) and a blend: the step
// from the last output to the sample, its speed low-passed, the blend weight from the
// speed's cutoff.
template <class T, class Step, class Blend>
std::vector<T> pass(const std::vector<T>& x, double fps, const OneEuroParams& p, Step step, Blend blend) {
  std::vector<T> out(x.size());
  if (x.empty()) return out;
  out[0] = x[0];
  double speed = 0;
  for (size_t t = 1; t < x.size(); ++t) {
    const double raw = step(out[t - 1], x[t]) * fps;
    speed += alpha(p.d_cutoff_hz, fps) * (raw - speed);
    out[t] = blend(out[t - 1], x[t], alpha(p.min_cutoff_hz + p.beta * std::fabs(speed), fps));
  }
  return out;
}

// Forward and backward passes, averaged by `blend` at one half.
template <class T, class Step, class Blend>
std::vector<T> zero_lag(const std::vector<T>& x, double fps, const OneEuroParams& p, Step step, Blend blend) {
  const std::vector<T> f = pass(x, fps, p, step, blend);
  const std::vector<T> rx(x.rbegin(), x.rend());
  std::vector<T> b = pass(rx, fps, p, step, blend);
  std::vector<T> out(x.size());
  for (size_t t = 0; t < x.size(); ++t) out[t] = blend(f[t], b[x.size() - 1 - t], 0.5);
  return out;
}

}  // namespace

std::vector<Vec3<double>> one_euro(const std::vector<Vec3<double>>& x, double fps, const OneEuroParams& p) {
  using V = Vec3<double>;
  return zero_lag(
      x, fps, p, [](const V& a, const V& b) { return norm(b - a); },
      [](const V& a, const V& b, double s) { return a + s * (b - a); });
}

std::vector<Quat<double>> one_euro(const std::vector<Quat<double>>& q, double fps, const OneEuroParams& p) {
  using Q = Quat<double>;
  return zero_lag(
      q, fps, p,
      [](const Q& a, const Q& b) {
        const double d = std::fabs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z);
        return 2 * std::acos(std::min(1.0, d));  // the angle between them
      },
      [](const Q& a, const Q& b, double s) { return slerp_shortest(a, b, s); });
}

}  // namespace haha
