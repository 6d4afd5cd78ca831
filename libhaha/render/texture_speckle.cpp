#include "render/texture_speckle.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "render/scatter.h"

namespace haha {

namespace {

int joint_part(int j) {
  if (j == 12) return kSpeckleNeck;
  if (j == 20 || j == 21 || (j >= 25 && j <= 54)) return kSpeckleHands;
  if (j == 7 || j == 8 || j == 10 || j == 11) return kSpeckleFeet;
  return -1;
}

float luminance(const float* p) { return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2]; }

}  // namespace

std::vector<int8_t> speckle_face_parts(const BodyModel& body) {
  std::vector<int8_t> part(size_t(body.num_faces), -1);
  const int J = 55;
  if (body.weights.size() != size_t(body.num_verts) * J) return part;
  for (int f = 0; f < body.num_body_faces(); ++f) {
    int best = -1;
    double best_w = -1;
    for (int j = 0; j < J; ++j) {
      double w = 0;
      for (int k = 0; k < 3; ++k) w += body.weights[size_t(body.faces[size_t(f) * 3 + k]) * J + j];
      if (w > best_w) best_w = w, best = j;
    }
    part[size_t(f)] = int8_t(joint_part(best));
  }
  return part;
}

TextureSpeckle texture_speckle(const float* rgb, const TextureCharts& charts, const std::vector<int8_t>& face_part) {
  const int W = charts.width, H = charts.height;
  std::vector<float> lum(size_t(W) * H);
  for (size_t i = 0; i < lum.size(); ++i) lum[i] = luminance(rgb + 3 * i);
  std::vector<int8_t> speck(size_t(W) * H, 0);  // 1 speckled, 0 not, per texel of a part
  detail::parallel_items(H, [&](int64_t j) {
    float window[(2 * kSpeckleRadius + 1) * (2 * kSpeckleRadius + 1)];
    for (int i = 0; i < W; ++i) {
      const int64_t t = j * W + i;
      if (charts.face[size_t(t)] < 0) continue;
      int n = 0;
      for (int y = std::max<int64_t>(0, j - kSpeckleRadius); y <= std::min<int64_t>(H - 1, j + kSpeckleRadius); ++y)
        for (int x = std::max(0, i - kSpeckleRadius); x <= std::min(W - 1, i + kSpeckleRadius); ++x)
          if (charts.face[size_t(y) * W + x] >= 0) window[n++] = lum[size_t(y) * W + x];
      std::nth_element(window, window + n / 2, window + n);
      speck[size_t(t)] = std::abs(lum[size_t(t)] - window[n / 2]) > float(kSpeckleStep);
    }
  });
  TextureSpeckle s;
  std::array<int64_t, kSpeckleParts> hits{};
  for (size_t t = 0; t < speck.size(); ++t) {
    const int32_t f = charts.face[t];
    if (f < 0) continue;
    ++s.all_texels;
    s.all_per_mille += speck[t];
    if (size_t(f) >= face_part.size() || face_part[size_t(f)] < 0) continue;
    ++s.texels[size_t(face_part[size_t(f)])];
    hits[size_t(face_part[size_t(f)])] += speck[t];
  }
  s.all_per_mille = s.all_texels ? 1000.0 * s.all_per_mille / double(s.all_texels) : 0.0;
  for (int p = 0; p < kSpeckleParts; ++p)
    s.per_mille[size_t(p)] = s.texels[size_t(p)] ? 1000.0 * double(hits[size_t(p)]) / double(s.texels[size_t(p)]) : 0.0;
  return s;
}

TextureSpeckle texture_speckle(const BodyModel& body, const std::vector<float>& rgb, int width, int height) {
  if (width <= 0 || height <= 0 || rgb.size() != size_t(width) * height * 3)
    fail("texture_speckle", "texture of " + std::to_string(rgb.size()) + " values is not " + std::to_string(width) +
                                "x" + std::to_string(height) + "x3");
  return texture_speckle(rgb.data(), texture_charts(body, width, height), speckle_face_parts(body));
}

}  // namespace haha
