// A small synthetic avatar for the format tests: a closed-ish tube body with SMPL-X's 55
// joints and parents, a UV map with a seam, up to 6 skinning influences per vertex (so two
// JOINTS/WEIGHTS sets), shape/expression/pose blend shapes, random Gaussians and texture.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "body/avatar.h"
#include "body/garment.h"

namespace haha::test {

inline const int kSmplxParents[55] = {-1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,  9,  12, 13, 14, 16,
                                      17, 18, 19, 15, 15, 15, 20, 25, 26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20,
                                      37, 38, 21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};

// rings x segments grid wrapped around the Y axis; the wrap column has its own UVs (seam).
inline BodyModel make_test_body(int rings = 10, int segments = 12, uint32_t seed = 1, bool with_posedirs = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  BodyModel b;
  b.source = "test body";
  const int V = rings * segments;
  b.num_verts = V;
  b.v_template.resize(size_t(V) * 3);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double a = 2 * M_PI * s / segments;
      const double rad = 0.15 + 0.05 * std::sin(r * 0.7);
      float* p = &b.v_template[size_t(r * segments + s) * 3];
      p[0] = float(rad * std::cos(a));
      p[1] = float(-0.9 + 1.7 * r / (rings - 1));
      p[2] = float(rad * std::sin(a));
    }
  // UVs: (segments + 1) x rings grid; column `segments` duplicates column 0 (the seam).
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s <= segments; ++s) {
      b.vt.push_back(float(s) / segments * 0.9f + 0.05f);
      b.vt.push_back(float(r) / (rings - 1) * 0.9f + 0.05f);
    }
  auto vid = [&](int r, int s) { return r * segments + (s % segments); };
  auto tid = [&](int r, int s) { return r * (segments + 1) + s; };
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const int f0[3] = {vid(r, s), vid(r, s + 1), vid(r + 1, s + 1)};
      const int t0[3] = {tid(r, s), tid(r, s + 1), tid(r + 1, s + 1)};
      const int f1[3] = {vid(r, s), vid(r + 1, s + 1), vid(r + 1, s)};
      const int t1[3] = {tid(r, s), tid(r + 1, s + 1), tid(r + 1, s)};
      for (int c = 0; c < 3; ++c) b.faces.push_back(f0[c]), b.ft.push_back(t0[c]);
      for (int c = 0; c < 3; ++c) b.faces.push_back(f1[c]), b.ft.push_back(t1[c]);
    }
  // A degenerate face (repeated vertex) at the end: must survive with its index.
  for (int c = 0; c < 3; ++c) b.faces.push_back(c == 2 ? 0 : c), b.ft.push_back(c == 2 ? 0 : c);
  b.num_faces = int(b.faces.size() / 3);
  b.parents.assign(kSmplxParents, kSmplxParents + 55);
  // Weights: 1..6 random joints per vertex, normalised.
  b.weights.assign(size_t(V) * 55, 0.0f);
  for (int v = 0; v < V; ++v) {
    const int k = 1 + int(rng() % 6);
    double sum = 0;
    std::vector<float> w(55, 0.0f);
    for (int i = 0; i < k; ++i) {
      const int j = int(rng() % 55);
      w[size_t(j)] += 0.05f + u(rng);
    }
    for (float x : w) sum += x;
    for (int j = 0; j < 55; ++j) b.weights[size_t(v) * 55 + j] = float(w[size_t(j)] / sum);
  }
  // Regressor: each joint = mean of 3 vertices.
  b.j_regressor.assign(size_t(55) * V, 0.0f);
  for (int j = 0; j < 55; ++j)
    for (int i = 0; i < 3; ++i) b.j_regressor[size_t(j) * V + (rng() % V)] += 1.0f / 3.0f;
  b.num_shape = 10;
  b.num_expr = 10;
  b.shapedirs.resize(size_t(V) * 3 * 20);
  for (float& x : b.shapedirs) x = 0.01f * (u(rng) - 0.5f);
  if (with_posedirs) {
    b.posedirs.resize(size_t(V) * 3 * 486);
    for (float& x : b.posedirs) x = 0.002f * (u(rng) - 0.5f);
  }
  return b;
}

inline Avatar make_test_avatar(int num_gaussians = 300, uint32_t seed = 2, int tex_w = 32, int tex_h = 24) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> nrm(0.0f, 1.0f);
  Avatar a;
  a.body = make_test_body();
  a.betas = {0.5f, -1.0f, 0.25f, 0.0f, 0.1f};
  a.expression = {0.2f, -0.3f};
  a.face_scale_divisor = 0.05f;
  a.texture.width = tex_w;
  a.texture.height = tex_h;
  a.texture.rgb.resize(size_t(tex_w) * tex_h * 3);
  for (float& x : a.texture.rgb) x = u(rng);
  BoundGaussians& g = a.gaussians;
  g.resize(num_gaussians);
  for (int i = 0; i < num_gaussians; ++i) {
    g.face[size_t(i)] = int32_t(rng() % uint32_t(a.body.num_faces));
    for (int k = 0; k < 3; ++k) g.offset[size_t(i) * 3 + k] = 0.2f * nrm(rng);
    float q[4], n = 0;
    for (float& x : q) x = nrm(rng), n += x * x;
    for (int k = 0; k < 4; ++k) g.rotation[size_t(i) * 4 + k] = q[k] / std::sqrt(n);
    for (int k = 0; k < 3; ++k) g.scale[size_t(i) * 3 + k] = std::exp(-5.0f + 3.0f * u(rng));
    for (int k = 0; k < 3; ++k) g.color[size_t(i) * 3 + k] = u(rng);
    g.opacity[size_t(i)] = 0.1f + 0.9f * u(rng);
  }
  return a;
}

// The test avatar without its degenerate last face (Gaussians on it move to face 0):
// Draco's edgebreaker drops degenerate faces, so only such a body is packed with it.
inline Avatar without_degenerate_face(Avatar a) {
  BodyModel& b = a.body;
  const int last = b.num_faces - 1;
  b.faces.resize(size_t(last) * 3);
  b.ft.resize(size_t(last) * 3);
  b.num_faces = last;
  for (int32_t& f : a.gaussians.face)
    if (f == last) f = 0;
  return a;
}

// A garment of two triangles below the tube's middle, hanging from the pelvis and both hips,
// its chart on the right fifth of the texture.
inline Garment make_test_garment() {
  Garment g;
  g.verts = {0.1f, -0.2f, 0.1f, -0.1f, -0.2f, 0.1f, 0.1f, -0.5f, 0.15f, -0.1f, -0.5f, 0.15f};
  g.faces = {0, 1, 2, 1, 3, 2};
  g.weights.assign(4 * size_t(kNumJoints), 0.0f);
  for (int v = 0; v < 4; ++v) {
    g.weights[size_t(v) * kNumJoints + 0] = 0.5f;
    g.weights[size_t(v) * kNumJoints + 1] = 0.25f;
    g.weights[size_t(v) * kNumJoints + 2] = 0.25f;
  }
  g.vt = {0.85f, 0.1f, 0.85f, 0.9f, 0.95f, 0.1f, 0.95f, 0.9f};
  g.ft = g.faces;
  g.chart = 0.2f;
  return g;
}

// The avatar with the test garment appended to its body, its first `n` Gaussians moved onto
// the garment's two faces.
inline Avatar with_test_garment(Avatar a, int n = 5) {
  const int first = a.body.num_faces;
  a.body = append_garment(a.body, make_test_garment());
  for (int i = 0; i < n && i < a.gaussians.size(); ++i) a.gaussians.face[size_t(i)] = first + i % 2;
  return a;
}

// The avatar with a mesh coverage on every body vertex (garment included, so attach one
// first): vertices cycle through 0 (cut), 1 (drawn) and 0.3 (cut, off the 8-bit grid).
inline Avatar with_test_coverage(Avatar a) {
  a.mesh_coverage.resize(size_t(a.body.num_verts));
  for (size_t v = 0; v < a.mesh_coverage.size(); ++v) a.mesh_coverage[v] = v % 3 == 0 ? 0.0f : v % 3 == 1 ? 1.0f : 0.3f;
  return a;
}

}  // namespace haha::test
