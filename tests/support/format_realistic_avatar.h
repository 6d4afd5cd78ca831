// A realistic-size avatar for the format's storage and quality measurements: the full
// procedural body (10,476 vertices, SMPL-X layout), ~12k Gaussians distributed like a
// filtered HAHA avatar (one per surviving face in face order, densified children appended,
// small offsets, rotations near identity, scales of a few percent of k, colours following
// the texture, opacities mostly near 1) and a smooth texture with fine detail.
// Distributions are stand-ins (no trained avatar is available); sizes depend on them.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "body/avatar.h"
#include "body/procedural_body.h"

namespace haha::test {

inline Texture make_realistic_texture(int size, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, 1.0f);
  Texture t;
  t.width = t.height = size;
  t.rgb.resize(size_t(size) * size * 3);
  // Low-frequency colour fields, a few hard edges (clothing seams), fine noise.
  float f[3][4];
  for (auto& c : f)
    for (float& x : c) x = n(rng);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float u = (x + 0.5f) / size, v = (y + 0.5f) / size;
      const bool shirt = v < 0.45f + 0.05f * std::sin(9 * u);
      for (int c = 0; c < 3; ++c) {
        float val = 0.45f + 0.12f * std::sin(3.1f * u * (1 + f[c][0]) + f[c][1]) * std::cos(2.3f * v * (1 + f[c][2]) + f[c][3]);
        val += shirt ? 0.15f * (c == 2) - 0.1f * (c == 0) : 0.08f * (c == 0);
        val += 0.025f * std::sin(60 * u + 40 * v + c);  // fabric-like fine pattern
        val += 0.01f * n(rng);                          // sensor-like noise
        t.rgb[(size_t(y) * size + x) * 3 + c] = std::min(1.0f, std::max(0.0f, val));
      }
    }
  return t;
}

inline Avatar make_realistic_avatar(int num_gaussians = 12000, int texture_size = 512, uint32_t seed = 3,
                                    BodyResolution resolution = BodyResolution::full) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> n(0.0f, 1.0f);
  Avatar a;
  a.body = make_procedural_body({resolution, 0});
  a.betas.resize(10);
  for (float& b : a.betas) b = 0.5f * n(rng);
  a.expression.assign(10, 0.0f);
  a.face_scale_divisor = 0.05f;
  a.texture = make_realistic_texture(texture_size, seed + 1);
  const int F = a.body.num_faces;
  // Survivors of filtering: ~75% of the Gaussians, one per face, in face order.
  const int survivors = std::min(F, num_gaussians * 3 / 4);
  std::vector<int> faces;
  for (int f = 0; f < F; ++f)
    if (u(rng) < float(survivors) / F) faces.push_back(f);
  while (int(faces.size()) < num_gaussians) faces.push_back(faces[rng() % faces.size()]);  // children
  faces.resize(size_t(num_gaussians));
  BoundGaussians& g = a.gaussians;
  g.resize(num_gaussians);
  auto sample_texture = [&](float uu, float vv, int c) {
    const int x = std::min(a.texture.width - 1, std::max(0, int(uu * a.texture.width)));
    const int y = std::min(a.texture.height - 1, std::max(0, int((1 - vv) * a.texture.height)));
    return a.texture.rgb[(size_t(y) * a.texture.width + x) * 3 + c];
  };
  for (int i = 0; i < num_gaussians; ++i) {
    const int f = faces[size_t(i)];
    const bool child = i >= survivors;
    g.face[size_t(i)] = f;
    for (int k = 0; k < 3; ++k) g.offset[size_t(i) * 3 + k] = (child ? 0.12f : 0.05f) * n(rng);
    if (child) g.offset[size_t(i) * 3 + 1] = std::fabs(g.offset[size_t(i) * 3 + 1]);  // outer side
    // Rotation: random axis, angle ~ |N(0, 0.5)|.
    float ax[3] = {n(rng), n(rng), n(rng)};
    const float al = std::sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    const float ang = 0.5f * std::fabs(n(rng));
    g.rotation[size_t(i) * 4] = std::cos(ang / 2);
    for (int k = 0; k < 3; ++k) g.rotation[size_t(i) * 4 + 1 + k] = std::sin(ang / 2) * ax[k] / al;
    // Scale: 0.1 * sigmoid(x) in units of k (the release's activation), x ~ N(-2, 0.8).
    for (int k = 0; k < 3; ++k) g.scale[size_t(i) * 3 + k] = 0.1f / (1 + std::exp(-(-2.0f + 0.8f * n(rng))));
    // Colour: the texture at the face's UV centroid, plus a little.
    float uu = 0, vv = 0;
    for (int c = 0; c < 3; ++c) {
      const int t = a.body.ft[size_t(f) * 3 + c];
      uu += a.body.vt[size_t(t) * 2] / 3;
      vv += a.body.vt[size_t(t) * 2 + 1] / 3;
    }
    for (int c = 0; c < 3; ++c)
      g.color[size_t(i) * 3 + c] = std::min(1.0f, std::max(0.0f, sample_texture(uu, vv, c) + 0.04f * n(rng)));
    g.opacity[size_t(i)] = std::min(1.0f, std::max(0.1f, 1.0f - std::fabs(0.3f * n(rng))));
  }
  return a;
}

}  // namespace haha::test
