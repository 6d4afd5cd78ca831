#include "train/texture_smooth.h"

#include <algorithm>

#include "core/error.h"

namespace haha {

std::vector<float> smooth_weights(const std::vector<float>& evidence, const TextureCharts& charts,
                                  double evidence_full) {
  if (evidence.size() != charts.face.size()) fail("smooth_weights", "evidence and charts differ in size");
  if (!(evidence_full > 0)) fail("smooth_weights", "evidence_full must be > 0");
  std::vector<float> a(evidence.size(), 0.0f);
  for (size_t t = 0; t < a.size(); ++t)
    if (charts.face[t] >= 0) a[t] = float(1.0 / (1.0 + double(evidence[t]) / evidence_full));
  return a;
}

template <class T>
T texture_smooth_loss(const T* tex, const float* a, int H, int W, int C, T* grad, T grad_scale) {
  const double count = double(H) * W * C;
  if (!(count > 0.0)) return T(0);
  const T k = T(1.0 / count);
  double sum = 0.0;
  // Rows in order: a deterministic sum; the work is a few operations per texel.
  auto pair = [&](int64_t i, int64_t j) {
    const T w = T(std::min(a[i], a[j]));
    if (!(w > T(0))) return;
    for (int c = 0; c < C; ++c) {
      const T d = tex[i * C + c] - tex[j * C + c];
      sum += double(w * d * d);
      if (grad) {
        const T g = T(2) * w * d * k * grad_scale;
        grad[i * C + c] += g;
        grad[j * C + c] -= g;
      }
    }
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int64_t i = int64_t(y) * W + x;
      if (x + 1 < W) pair(i, i + 1);
      if (y + 1 < H) pair(i, i + W);
    }
  return T(sum / count);
}

template float texture_smooth_loss<float>(const float*, const float*, int, int, int, float*, float);
template double texture_smooth_loss<double>(const double*, const float*, int, int, int, double*, double);

}  // namespace haha
