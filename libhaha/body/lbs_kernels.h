// The pieces of SMPL-X LBS (body/lbs.cpp) that the CPU and CUDA launchers share:
//   - the precomputed model (LbsModelData: CSR skinning weights, block-sparse pose
//     correctives, column-major shape directions, folded joint regressor) and its raw
//     pointer view LbsModelView, which a CUDA launcher copies to the device as is;
//   - the per-vertex kernels (HAHA_HD functions of the vertex index);
//   - the per-frame joint chain (55 joints, run on the host by both backends) forward and
//     backward, the latter from the per-vertex sums acc = [dA (55x12) | dfeat (486) |
//     dcoef (num_betas + num_expr) | dtransl (3)].
// The backward kernels scatter-add through an accumulation policy (core/hd.h PlainAdd on
// the CPU, atomics on the GPU); the operations per vertex are the same.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/lbs.h"
#include "core/hd.h"
#include "core/math.h"

namespace haha {

inline constexpr int kLbsBlock = 27;                    // 3 coords x 9 pose features of one joint
inline constexpr int kLbsAccA = kNumJoints * 12;        // dL/dA_j, 3x4 row-major per joint
inline constexpr int kLbsAccF = kNumPoseFeatures;       // dL/dfeature
// Size of the per-vertex sums of one frame for ncoef = num_betas + num_expr.
inline constexpr int lbs_acc_size(int ncoef) { return kLbsAccA + kLbsAccF + ncoef + 3; }

// Raw-pointer view of the precomputed model (host or device memory).
template <class T>
struct LbsModelView {
  int V, S, num_shape;
  const T* v_template;  // (V*3)
  const T* shapedirs;   // (S, V*3) column-major
  const int32_t* w_off;
  const int32_t* w_joint;
  const T* w_val;
  const int32_t* p_off;   // (V+1) block ranges
  const int32_t* p_feat;  // block -> feature group j-1 (0..53)
  const T* p_data;        // (blocks, 3, 9)
};

// Per-frame inputs of the vertex kernels.
template <class T>
struct LbsFrameView {
  const T* betas;  // (nb)
  int nb;
  const T* expr;  // (ne)
  int ne;
  const T* features;  // (486)
  const T* A;         // (55, 12) skinning transforms, 3x4 row-major
  T transl[3];
};

// v_shaped[r0, r1) of the flat (V*3) array: template + sum_k coef_k column_k.
template <class T>
HAHA_HD void lbs_shape_range(const LbsModelView<T>& m, const LbsFrameView<T>& f, int64_t r0, int64_t r1, T* vs) {
  for (int64_t i = r0; i < r1; ++i) vs[i] = m.v_template[i];
  const int64_t n3 = int64_t(3) * m.V;
  for (int k = 0; k < f.nb + f.ne; ++k) {
    const int col = k < f.nb ? k : m.num_shape + (k - f.nb);
    const T b = k < f.nb ? f.betas[k] : f.expr[k - f.nb];
    const T* d = m.shapedirs + col * n3;
    for (int64_t i = r0; i < r1; ++i) vs[i] += b * d[i];
  }
}

// v_posed of vertex v: v_shaped + pose correctives.
template <class T>
HAHA_HD void lbs_posed(const LbsModelView<T>& m, const LbsFrameView<T>& f, int v, const T* v_shaped, T vp[3]) {
  for (int c = 0; c < 3; ++c) vp[c] = v_shaped[3 * v + c];
  for (int b = m.p_off[v]; b < m.p_off[v + 1]; ++b) {
    const T* fe = f.features + 9 * m.p_feat[b];
    const T* d = m.p_data + int64_t(kLbsBlock) * b;
    for (int c = 0; c < 3; ++c) {
      T acc = 0;
      for (int k = 0; k < 9; ++k) acc += d[9 * c + k] * fe[k];
      vp[c] += acc;
    }
  }
}

// Blended 3x4 transform of vertex v.
template <class T>
HAHA_HD void lbs_blend(const LbsModelView<T>& m, const T* A, int v, T M[12]) {
  for (int i = 0; i < 12; ++i) M[i] = 0;
  for (int i = m.w_off[v]; i < m.w_off[v + 1]; ++i) {
    const T w = m.w_val[i];
    const T* a = A + 12 * m.w_joint[i];
    for (int k = 0; k < 12; ++k) M[k] += w * a[k];
  }
}

// Vertex v from its v_shaped: correctives, skinning, translation.
template <class T>
HAHA_HD void lbs_vertex_forward(const LbsModelView<T>& m, const LbsFrameView<T>& f, int v, const T* v_shaped,
                                T* verts, T* v_posed) {
  T vp[3], M[12];
  lbs_posed(m, f, v, v_shaped, vp);
  lbs_blend(m, f.A, v, M);
  for (int r = 0; r < 3; ++r)
    verts[3 * v + r] = M[4 * r] * vp[0] + M[4 * r + 1] * vp[1] + M[4 * r + 2] * vp[2] + M[4 * r + 3] + f.transl[r];
  if (v_posed)
    for (int c = 0; c < 3; ++c) v_posed[3 * v + c] = vp[c];
}

// Adds vertex v's contributions to dA (55x12), dfeat (486), dtransl (3) and writes
// dL/dv_shaped (= dL/dv_posed) of the vertex to d_vs[0..2].
template <class T, class Add = PlainAdd>
HAHA_HD void lbs_vertex_backward(const LbsModelView<T>& m, const LbsFrameView<T>& f, int v, const T* v_posed,
                                 const T* d_verts, T* dA, T* dfeat, T* dtransl, T d_vs[3], Add add = {}) {
  const T g[3] = {d_verts[3 * v], d_verts[3 * v + 1], d_verts[3 * v + 2]};
  if (g[0] == T(0) && g[1] == T(0) && g[2] == T(0)) {  // exact: contributes nothing
    d_vs[0] = d_vs[1] = d_vs[2] = T(0);
    return;
  }
  const T vp[3] = {v_posed[3 * v], v_posed[3 * v + 1], v_posed[3 * v + 2]};
  T M[12];
  lbs_blend(m, f.A, v, M);
  for (int r = 0; r < 3; ++r) add(&dtransl[r], g[r]);
  // out = M [vp; 1]: dM = g [vp; 1]^T, dvp = M_R^T g
  T G[12];
  for (int r = 0; r < 3; ++r) {
    G[4 * r] = g[r] * vp[0];
    G[4 * r + 1] = g[r] * vp[1];
    G[4 * r + 2] = g[r] * vp[2];
    G[4 * r + 3] = g[r];
  }
  for (int i = m.w_off[v]; i < m.w_off[v + 1]; ++i) {
    const T w = m.w_val[i];
    T* a = dA + 12 * m.w_joint[i];
    for (int k = 0; k < 12; ++k) add(&a[k], w * G[k]);
  }
  T dvp[3];
  for (int c = 0; c < 3; ++c) dvp[c] = M[c] * g[0] + M[4 + c] * g[1] + M[8 + c] * g[2];
  for (int b = m.p_off[v]; b < m.p_off[v + 1]; ++b) {
    T* df = dfeat + 9 * m.p_feat[b];
    const T* d = m.p_data + int64_t(kLbsBlock) * b;
    for (int k = 0; k < 9; ++k) add(&df[k], d[k] * dvp[0] + d[9 + k] * dvp[1] + d[18 + k] * dvp[2]);
  }
  // v_shaped enters v_posed with identity Jacobian.
  for (int c = 0; c < 3; ++c) d_vs[c] = dvp[c];
}

// dcoef_k += <column_k[r0, r1), d_vs[r0, r1)>.
template <class T, class Add = PlainAdd>
HAHA_HD void lbs_shape_backward_range(const LbsModelView<T>& m, const LbsFrameView<T>& f, int64_t r0, int64_t r1,
                                      const T* d_vs, T* dcoef, Add add = {}) {
  const int64_t n3 = int64_t(3) * m.V;
  for (int k = 0; k < f.nb + f.ne; ++k) {
    const int col = k < f.nb ? k : m.num_shape + (k - f.nb);
    const T* d = m.shapedirs + col * n3;
    T acc = 0;
    for (int64_t i = r0; i < r1; ++i) acc += d[i] * d_vs[i - r0];
    add(&dcoef[k], acc);
  }
}

// ---- host side (body/lbs.cpp; instantiated for float and double) ----

// The precomputed model arrays (host memory).
template <class T>
struct LbsModelData {
  int V = 0, S = 0, num_shape = 0, num_expr = 0;
  std::vector<T> v_template, shapedirs, j_template, j_shapedirs;
  int parents[kNumJoints];
  std::vector<int32_t> w_off, w_joint, p_off, p_feat;
  std::vector<T> w_val, p_data;

  LbsModelView<T> view() const {
    return {V, S, num_shape, v_template.data(), shapedirs.data(), w_off.data(), w_joint.data(), w_val.data(),
            p_off.data(), p_feat.data(), p_data.data()};
  }
};

// Validates the model's array sizes (haha::Error naming model.source) and precomputes.
template <class T>
LbsModelData<T> lbs_model_data(const BodyModel& model);

// Frame setup before the vertex pass: checks the coefficient counts (haha::Error naming
// `where`), fills c.joints_rest, local_rot, world, skinning, pose_feature and writes the
// skinning transforms A (55 x 12, 3x4 row-major).
template <class T>
void lbs_frame_forward(const LbsModelData<T>& d, const SmplxView<T>& p, LbsCache<T>& c, T* A,
                       const std::string& where);

// A (55 x 12) from a filled cache's skinning transforms.
template <class T>
void lbs_skinning_matrices(const LbsCache<T>& c, T* A);

// The joint chain's backward: from the per-vertex sums acc (layout above, already
// reduced over vertices; acc = null means zero) and dL/djoints (55, 3, may be null), ADDS
// dL/d(pose, betas, expression, transl) into grad.
template <class T>
void lbs_frame_backward(const LbsModelData<T>& d, const SmplxView<T>& p, const LbsCache<T>& c, const T* acc,
                        const T* d_joints, SmplxGrad<T>& grad);

}  // namespace haha
