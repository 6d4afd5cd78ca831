// Small synthetic SMPL-X-layout body models for the body / io tests and the LBS benchmark:
// 55 joints with the SMPL-X parents, a cluster of vertices around each joint, random
// shape / expression directions, pose correctives on the blocks of each vertex's joints,
// 1..4 skinning influences per vertex. Independent of the procedural body generator.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "body/body_model.h"

namespace haha::test {

inline constexpr int kSmplxParents[kNumJoints] = {
    -1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,  9,  12, 13, 14, 16, 17, 18, 19, 15, 15, 15, 20, 25, 26,
    20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38, 21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};

struct SynthOptions {
  int verts_per_joint = 8;        // cluster j = vertices [j * m, (j + 1) * m)
  int total_verts = 0;            // > 0: clusters of near-equal size summing to this instead
  int num_shape = 10, num_expr = 10;
  int max_influences = 3;        // own joint, parent, grandparent, a child (<= 4)
  bool dense_posedirs = false;   // all 54 blocks of every vertex non-zero
  bool with_posedirs = true;
  std::vector<int> rigid_joints;  // clusters skinned 100% to their joint, no correctives
  bool all_rigid = false;         // every cluster rigid (consistent-regressor test)
  double shape_scale = 0.01, pose_scale = 0.01;
  uint32_t seed = 1;
};

inline BodyModel make_synthetic_model(const SynthOptions& o) {
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> u01(0.2, 1.0);
  std::vector<int> start(kNumJoints + 1, 0);
  for (int j = 0; j < kNumJoints; ++j)
    start[j + 1] = start[j] + (o.total_verts > 0 ? o.total_verts / kNumJoints + (j < o.total_verts % kNumJoints)
                                                 : o.verts_per_joint);
  BodyModel b;
  b.source = "synthetic";
  b.num_verts = start[kNumJoints];
  b.num_shape = o.num_shape;
  b.num_expr = o.num_expr;
  const int V = b.num_verts, S = o.num_shape + o.num_expr;
  b.parents.assign(kSmplxParents, kSmplxParents + kNumJoints);

  std::vector<double> J(3 * kNumJoints, 0.0);
  for (int j = 1; j < kNumJoints; ++j) {
    double d[3] = {u(rng), u(rng), u(rng)};
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 1e-9;
    for (int c = 0; c < 3; ++c) J[3 * j + c] = J[3 * b.parents[j] + c] + 0.1 * d[c] / n;
  }
  std::vector<std::vector<int>> children(kNumJoints);
  for (int j = 1; j < kNumJoints; ++j) children[b.parents[j]].push_back(j);

  b.v_template.resize(size_t(V) * 3);
  b.weights.assign(size_t(V) * kNumJoints, 0.0f);
  b.j_regressor.assign(size_t(kNumJoints) * V, 0.0f);
  b.shapedirs.resize(size_t(V) * 3 * S);
  for (auto& x : b.shapedirs) x = float(o.shape_scale * u(rng));
  if (o.with_posedirs) b.posedirs.assign(size_t(V) * 3 * kNumPoseFeatures, 0.0f);

  for (int j = 0; j < kNumJoints; ++j) {
    const bool rigid = o.all_rigid || std::find(o.rigid_joints.begin(), o.rigid_joints.end(), j) != o.rigid_joints.end();
    const int m = start[j + 1] - start[j];
    for (int i = 0; i < m; ++i) {
      const int v = start[j] + i;
      for (int c = 0; c < 3; ++c) b.v_template[3 * v + c] = float(J[3 * j + c] + 0.04 * u(rng));
      b.j_regressor[size_t(j) * V + v] = 1.0f / float(m);
      // influences
      std::vector<int> inf = {j};
      if (!rigid) {
        if (o.max_influences >= 2 && b.parents[j] >= 0) inf.push_back(b.parents[j]);
        if (o.max_influences >= 3 && inf.size() == 2 && b.parents[inf[1]] >= 0) inf.push_back(b.parents[inf[1]]);
        if (o.max_influences >= 4 && !children[j].empty()) inf.push_back(children[j][i % children[j].size()]);
      }
      // Weights are multiples of 1/64 so that they sum to exactly 1 in float (as real
      // weights do up to rounding); the own joint keeps the remainder (>= 1/4).
      double wsum = 0;
      std::vector<double> w(inf.size());
      for (size_t k = 0; k < inf.size(); ++k) wsum += (w[k] = (k == 0 ? 2.0 : 1.0) * u01(rng));
      double rest = 1.0;
      for (size_t k = 1; k < inf.size(); ++k) {
        w[k] = std::max(1.0, std::round(64.0 * w[k] / wsum)) / 64.0;
        rest -= w[k];
      }
      w[0] = rest;
      for (size_t k = 0; k < inf.size(); ++k) b.weights[size_t(v) * kNumJoints + inf[k]] += float(w[k]);
      if (!o.with_posedirs || rigid) continue;
      for (int f = 0; f < kNumJoints - 1; ++f) {
        const bool on = o.dense_posedirs || std::find(inf.begin(), inf.end(), f + 1) != inf.end();
        if (!on) continue;
        for (int c = 0; c < 3; ++c)
          for (int k = 0; k < 9; ++k)
            b.posedirs[(size_t(3) * v + c) * kNumPoseFeatures + 9 * f + k] = float(o.pose_scale * u(rng));
      }
    }
  }
  // Triangles inside each cluster.
  for (int j = 0; j < kNumJoints; ++j)
    for (int v = start[j]; v + 2 < start[j + 1]; ++v) {
      b.faces.insert(b.faces.end(), {v, v + 1, v + 2});
    }
  b.num_faces = int(b.faces.size() / 3);
  return b;
}

// Adds the optional keys (hand PCA, landmarks, UV map) so file round trips cover them.
inline void add_optional_keys(BodyModel& b, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (auto* v : {&b.hands_components_l, &b.hands_components_r}) {
    v->resize(45 * 45);
    for (auto& x : *v) x = u(rng);
  }
  for (auto* v : {&b.hands_mean_l, &b.hands_mean_r}) {
    v->resize(45);
    for (auto& x : *v) x = 0.1f * u(rng);
  }
  const int L = 5;
  for (int i = 0; i < L; ++i) {
    b.lmk_faces_idx.push_back(i % b.num_faces);
    b.lmk_bary_coords.insert(b.lmk_bary_coords.end(), {0.2f, 0.3f, 0.5f});
  }
  // UVs: one per corner (every face its own UV triangle: maximal seams).
  b.ft.resize(b.faces.size());
  b.vt.resize(b.faces.size() * 2);
  for (size_t i = 0; i < b.faces.size(); ++i) {
    b.ft[i] = int32_t(i);
    b.vt[2 * i] = 0.5f + 0.5f * u(rng);
    b.vt[2 * i + 1] = 0.5f + 0.5f * u(rng);
  }
}

}  // namespace haha::test
