// SMPL-X LBS forward and hand-written backward (docs/method.md section 5).
//
// Data layout chosen for one-core speed (the per-vertex work is a few hundred flops, so
// memory traffic decides):
//   - skinning weights as CSR per vertex (zeros skipped: SMPL-X has a handful per vertex);
//   - pose correctives as CSR per vertex of 27-value blocks (3 coords x 9 features) per
//     joint, blocks that are exactly zero dropped (no thresholding: results are exact);
//   - shapedirs stored column-major (S, V*3): v_shaped is v_template plus one contiguous,
//     vectorised axpy per coefficient the caller gives (10 betas of a 400-column file read
//     10 columns, not 10 values out of every 1600-byte row);
//   - the joint regressor folded into j_template (55,3) and j_shapedirs (55,3,S), so rest
//     joints cost 55*3*(nb+ne) flops instead of a pass over the vertices (exact: J is
//     linear in the coefficients).
// Per-vertex kernels are HAHA_HD functions of the vertex index over raw pointers so a CUDA
// launcher can call them unchanged (the shape axpy / dot passes are plain loops over a
// column, coalesced on a GPU as they are). The CPU launcher works in chunks of kChunk
// vertices: shape pass, then the vertex kernel, with the chunk hot in L1. The backward
// reduces per-joint / per-feature / per-coefficient sums per chunk and adds the chunks in
// order, so results do not depend on the thread count. The kernels, the model arrays and
// the per-frame joint chain live in body/lbs_kernels.h, shared with the CUDA launcher.
#include "body/lbs.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>

#include "body/lbs_kernels.h"
#include "body/rotation.h"
#include "core/error.h"
#include "core/parallel.h"

namespace haha {
namespace {

constexpr int kJ = kNumJoints;
constexpr int kChunk = 256;               // vertices per reduction chunk
constexpr int kMinParallelChunks = 8;     // below this a parallel region costs more than it saves
constexpr int kAccA = kLbsAccA;
constexpr int kAccF = kLbsAccF;

std::string where_of(const BodyModel& m) { return m.source.empty() ? std::string("body model") : m.source; }

}  // namespace

template <class T>
struct Lbs<T>::Data : LbsModelData<T> {
  explicit Data(LbsModelData<T>&& d) : LbsModelData<T>(std::move(d)) {}
};

template <class T>
LbsModelData<T> lbs_model_data(const BodyModel& model) {
  const std::string where = where_of(model);
  const int V = model.num_verts;
  const int S = model.num_shape + model.num_expr;
  auto check = [&](const char* key, size_t got, size_t want) {
    if (got != want)
      fail(where, std::string(key) + ": has " + std::to_string(got) + " values, LBS needs " + std::to_string(want));
  };
  if (V <= 0) fail(where, "v_template: no vertices");
  if (model.num_shape < 0 || model.num_expr < 0) fail(where, "shapedirs: negative column count");
  check("v_template", model.v_template.size(), size_t(V) * 3);
  check("weights", model.weights.size(), size_t(V) * kJ);
  const bool fixed_joints = model.j_regressor.empty() && !model.joints_rest.empty();
  if (fixed_joints) {
    check("joints_rest", model.joints_rest.size(), size_t(kJ) * 3);
    for (float x : model.shapedirs)
      if (x != 0.0f) fail(where, "fixed rest joints (no J_regressor) need a body without shape directions");
  } else {
    check("J_regressor", model.j_regressor.size(), size_t(kJ) * V);
  }
  check("kintree_table", model.parents.size(), kJ);
  check("shapedirs", model.shapedirs.size(), size_t(V) * 3 * S);
  if (!model.posedirs.empty()) check("posedirs", model.posedirs.size(), size_t(V) * 3 * kNumPoseFeatures);
  for (int j = 1; j < kJ; ++j)
    if (model.parents[j] < 0 || model.parents[j] >= j)
      fail(where, "kintree_table: joint " + std::to_string(j) + " has parent " + std::to_string(model.parents[j]) +
                      " (parents must precede their children)");

  LbsModelData<T> dd;
  LbsModelData<T>* d = &dd;
  d->V = V;
  d->S = S;
  d->num_shape = model.num_shape;
  d->num_expr = model.num_expr;
  d->parents[0] = -1;
  for (int j = 1; j < kJ; ++j) d->parents[j] = model.parents[j];
  d->v_template.assign(model.v_template.begin(), model.v_template.end());
  d->shapedirs.resize(size_t(V) * 3 * S);  // transpose to column-major
  for (size_t r = 0; r < size_t(V) * 3; ++r)
    for (int k = 0; k < S; ++k) d->shapedirs[size_t(k) * V * 3 + r] = T(model.shapedirs[r * S + k]);

  // Joint regressor folded into the template and the shape directions (double sums).
  d->j_template.assign(size_t(kJ) * 3, T(0));
  d->j_shapedirs.assign(size_t(kJ) * 3 * S, T(0));
  std::vector<double> jt(3), js(size_t(3) * S);
  for (int j = 0; j < kJ && fixed_joints; ++j)
    for (int c = 0; c < 3; ++c) d->j_template[3 * j + c] = T(model.joints_rest[3 * size_t(j) + c]);
  for (int j = 0; j < kJ && !fixed_joints; ++j) {
    std::fill(jt.begin(), jt.end(), 0.0);
    std::fill(js.begin(), js.end(), 0.0);
    const float* reg = model.j_regressor.data() + size_t(j) * V;
    for (int v = 0; v < V; ++v) {
      const double r = reg[v];
      if (r == 0) continue;
      for (int c = 0; c < 3; ++c) {
        jt[c] += r * model.v_template[3 * size_t(v) + c];
        const float* row = model.shapedirs.data() + (size_t(3) * v + c) * S;
        for (int k = 0; k < S; ++k) js[size_t(c) * S + k] += r * row[k];
      }
    }
    for (int c = 0; c < 3; ++c) d->j_template[3 * j + c] = T(jt[c]);
    for (size_t i = 0; i < js.size(); ++i) d->j_shapedirs[size_t(j) * 3 * S + i] = T(js[i]);
  }

  // The rest displacement joins the template after the joints were regressed from the bare
  // surface (body_model.h): every backend adds the template, so they all see it.
  if (!model.rest_offsets.empty()) {
    check("rest_offsets", model.rest_offsets.size(), size_t(V) * 3);
    for (size_t i = 0; i < size_t(V) * 3; ++i) d->v_template[i] += T(model.rest_offsets[i]);
  }

  // Sparse skinning weights.
  d->w_off.assign(V + 1, 0);
  for (int v = 0; v < V; ++v) {
    for (int j = 0; j < kJ; ++j) {
      const float w = model.weights[size_t(v) * kJ + j];
      if (w != 0.0f) {
        d->w_joint.push_back(j);
        d->w_val.push_back(T(w));
      }
    }
    d->w_off[v + 1] = int32_t(d->w_joint.size());
  }

  // Pose correctives as per-vertex blocks, all-zero blocks dropped.
  d->p_off.assign(V + 1, 0);
  if (!model.posedirs.empty()) {
    for (int v = 0; v < V; ++v) {
      for (int f = 0; f < kJ - 1; ++f) {
        bool nonzero = false;
        for (int c = 0; c < 3 && !nonzero; ++c) {
          const float* p = model.posedirs.data() + (size_t(3) * v + c) * kNumPoseFeatures + 9 * f;
          for (int k = 0; k < 9; ++k) nonzero |= (p[k] != 0.0f);
        }
        if (!nonzero) continue;
        d->p_feat.push_back(f);
        for (int c = 0; c < 3; ++c) {
          const float* p = model.posedirs.data() + (size_t(3) * v + c) * kNumPoseFeatures + 9 * f;
          for (int k = 0; k < 9; ++k) d->p_data.push_back(T(p[k]));
        }
      }
      d->p_off[v + 1] = int32_t(d->p_feat.size());
    }
  }
  return dd;
}

template <class T>
Lbs<T>::Lbs(const BodyModel& model) : model_(&model), num_verts_(model.num_verts) {
  data_ = std::make_shared<const Data>(lbs_model_data<T>(model));
}

template <class T>
void lbs_frame_forward(const LbsModelData<T>& d, const SmplxView<T>& p, LbsCache<T>& c, T* A,
                       const std::string& where) {
  if (p.num_betas > d.num_shape || p.num_expr > d.num_expr || p.num_betas < 0 || p.num_expr < 0)
    fail(where, "LBS: " + std::to_string(p.num_betas) + " betas / " + std::to_string(p.num_expr) +
                    " expression values given, model has " + std::to_string(d.num_shape) + " / " +
                    std::to_string(d.num_expr));
  c.local_rot.resize(kJ);
  c.world.resize(kJ);
  c.skinning.resize(kJ);
  c.pose_feature.resize(kNumPoseFeatures);
  c.joints_rest.resize(size_t(kJ) * 3);

  // Rest joints: J = j_template + j_shapedirs . [betas, expression]
  const int S = d.S;
  for (int r = 0; r < kJ * 3; ++r) {
    const T* row = d.j_shapedirs.data() + size_t(r) * S;
    T acc = d.j_template[r];
    for (int k = 0; k < p.num_betas; ++k) acc += row[k] * p.betas[k];
    for (int k = 0; k < p.num_expr; ++k) acc += row[d.num_shape + k] * p.expression[k];
    c.joints_rest[r] = acc;
  }
  // Local rotations, pose features, chain, skinning transforms.
  for (int j = 0; j < kJ; ++j) {
    const Vec3<T> w = Vec3<T>::load(p.pose + 3 * j);
    c.local_rot[j] = rodrigues(w);
    if (j > 0)
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) c.pose_feature[9 * (j - 1) + 3 * r + s] = c.local_rot[j].a[r][s] - (r == s ? T(1) : T(0));
    const Vec3<T> J = Vec3<T>::load(&c.joints_rest[3 * j]);
    if (j == 0) {
      c.world[0] = {c.local_rot[0], J};
    } else {
      const int par = d.parents[j];
      const Vec3<T> Jp = Vec3<T>::load(&c.joints_rest[3 * par]);
      c.world[j] = c.world[par] * Rigid<T>{c.local_rot[j], J - Jp};
    }
    c.skinning[j] = {c.world[j].R, c.world[j].t - c.world[j].R * J};
  }
  lbs_skinning_matrices(c, A);
}

template <class T>
void lbs_skinning_matrices(const LbsCache<T>& c, T* A) {
  for (int j = 0; j < kJ; ++j)
    for (int r = 0; r < 3; ++r) {
      for (int s = 0; s < 3; ++s) A[12 * j + 4 * r + s] = c.skinning[j].R.a[r][s];
      A[12 * j + 4 * r + 3] = c.skinning[j].t[r];
    }
}

template <class T>
void lbs_frame_backward(const LbsModelData<T>& d, const SmplxView<T>& p, const LbsCache<T>& c, const T* acc,
                        const T* d_joints, SmplxGrad<T>& grad) {
  const int nb = p.num_betas, ne = p.num_expr, ncoef = nb + ne;
  std::vector<T> zeros;
  if (!acc) {
    zeros.assign(size_t(lbs_acc_size(ncoef)), T(0));
    acc = zeros.data();
  }
  const T* dA = acc;
  const T* dfeat = dA + kAccA;
  std::vector<T> dcoef(dA + kAccA + kAccF, dA + kAccA + kAccF + ncoef);
  const T* dtr = dA + kAccA + kAccF + ncoef;
  for (int r = 0; r < 3; ++r) grad.transl[r] += dtr[r];

  // Through A_j = [G_j.R | G_j.t - G_j.R J_j] and the joint outputs G_j.t + transl.
  Mat3<T> dGR[kJ];
  Vec3<T> dGt[kJ], dJ[kJ];
  for (int j = 0; j < kJ; ++j) {
    const Vec3<T> J = Vec3<T>::load(&c.joints_rest[3 * j]);
    Mat3<T> dAR;
    Vec3<T> dAt;
    for (int r = 0; r < 3; ++r) {
      for (int s = 0; s < 3; ++s) dAR.a[r][s] = dA[12 * j + 4 * r + s];
      dAt[r] = dA[12 * j + 4 * r + 3];
    }
    dGR[j] = dAR + T(-1) * outer(dAt, J);
    dGt[j] = dAt;
    dJ[j] = -(transpose(c.world[j].R) * dAt);
    if (d_joints) {
      const Vec3<T> dj = Vec3<T>::load(d_joints + 3 * j);
      dGt[j] += dj;
      for (int r = 0; r < 3; ++r) grad.transl[r] += dj[r];
    }
  }
  // Chain, children before parents: G_j = G_p [R_j | J_j - J_p].
  Mat3<T> dR[kJ];
  for (int j = kJ - 1; j >= 1; --j) {
    const int par = d.parents[j];
    const Mat3<T> GpRt = transpose(c.world[par].R);
    const Vec3<T> rel = Vec3<T>::load(&c.joints_rest[3 * j]) - Vec3<T>::load(&c.joints_rest[3 * par]);
    dR[j] = GpRt * dGR[j];
    dGR[par] = dGR[par] + dGR[j] * transpose(c.local_rot[j]) + outer(dGt[j], rel);
    dGt[par] += dGt[j];
    const Vec3<T> drel = GpRt * dGt[j];
    dJ[j] += drel;
    dJ[par] -= drel;
  }
  dR[0] = dGR[0];
  dJ[0] += dGt[0];
  for (int j = 0; j < kJ; ++j) {
    if (j > 0) dR[j] = dR[j] + Mat3<T>::load(dfeat + 9 * (j - 1));
    const Vec3<T> g = rodrigues_backward(Vec3<T>::load(p.pose + 3 * j), dR[j]);
    for (int r = 0; r < 3; ++r) grad.pose[3 * j + r] += g[r];
  }
  // Rest joints are linear in the coefficients.
  const int S = d.S;
  for (int j = 0; j < kJ; ++j)
    for (int r = 0; r < 3; ++r) {
      const T g = dJ[j][r];
      if (g == T(0)) continue;
      const T* row = d.j_shapedirs.data() + size_t(3 * j + r) * S;
      for (int k = 0; k < nb; ++k) dcoef[k] += row[k] * g;
      for (int k = 0; k < ne; ++k) dcoef[nb + k] += row[d.num_shape + k] * g;
    }
  for (int k = 0; k < nb; ++k) grad.betas[k] += dcoef[k];
  for (int k = 0; k < ne; ++k) grad.expression[k] += dcoef[nb + k];
}

template <class T>
void Lbs<T>::forward(const SmplxView<T>& p, T* verts, T* joints, LbsCache<T>* cache) const {
  const Data& d = *data_;
  LbsCache<T> local;
  LbsCache<T>& c = cache ? *cache : local;
  T A[kJ * 12];
  lbs_frame_forward(d, p, c, A, where_of(*model_));
  LbsFrameView<T> f{p.betas, p.num_betas, p.expression, p.num_expr, c.pose_feature.data(), A, {0, 0, 0}};
  if (p.transl)
    for (int r = 0; r < 3; ++r) f.transl[r] = p.transl[r];

  c.v_shaped.resize(size_t(d.V) * 3);  // (scratch when no cache was given)
  T* vs = c.v_shaped.data();
  T* vp = nullptr;
  if (cache) {
    c.v_posed.resize(size_t(d.V) * 3);
    vp = c.v_posed.data();
  }
  const LbsModelView<T> m = d.view();
  const int V = d.V;
  const int64_t chunks = (V + kChunk - 1) / kChunk;
  auto run = [&](int64_t ch) {
    const int begin = int(ch) * kChunk, end = std::min<int>(V, begin + kChunk);
    lbs_shape_range(m, f, int64_t(3) * begin, int64_t(3) * end, vs);
    for (int v = begin; v < end; ++v) lbs_vertex_forward(m, f, v, vs, verts, vp);
  };
  if (chunks >= kMinParallelChunks)
    parallel_for(chunks, run);
  else
    for (int64_t ch = 0; ch < chunks; ++ch) run(ch);
  if (joints)
    for (int j = 0; j < kJ; ++j)
      for (int r = 0; r < 3; ++r) joints[3 * j + r] = c.world[j].t[r] + f.transl[r];
}

template <class T>
void Lbs<T>::backward(const SmplxView<T>& p, const LbsCache<T>& c, const T* d_verts, const T* d_joints,
                      SmplxGrad<T>& grad) const {
  const Data& d = *data_;
  const std::string where = where_of(*model_);
  if (c.v_posed.size() != size_t(d.V) * 3 || c.world.size() != size_t(kJ))
    fail(where, "LBS backward: cache was not filled by forward()");
  if (grad.betas.size() < size_t(p.num_betas) || grad.expression.size() < size_t(p.num_expr))
    fail(where, "LBS backward: gradient not sized for the parameters (use make_grad)");
  const int nb = p.num_betas, ne = p.num_expr, ncoef = nb + ne;
  const int acc_size = lbs_acc_size(ncoef);

  T A[kJ * 12];
  lbs_skinning_matrices(c, A);
  const LbsFrameView<T> f{p.betas, nb, p.expression, ne, c.pose_feature.data(), A, {0, 0, 0}};
  const LbsModelView<T> m = d.view();

  // Per-chunk partial sums, reduced in chunk order (deterministic for any thread count).
  std::vector<T> acc;
  if (d_verts) {
    const int V = d.V;
    const int64_t chunks = (V + kChunk - 1) / kChunk;
    acc.assign(size_t(chunks) * acc_size, T(0));
    auto run = [&](int64_t ch) {
      T* a = acc.data() + size_t(ch) * acc_size;
      const int begin = int(ch) * kChunk, end = std::min<int>(V, begin + kChunk);
      T d_vs[3 * kChunk];
      for (int v = begin; v < end; ++v)
        lbs_vertex_backward(m, f, v, c.v_posed.data(), d_verts, a, a + kAccA, a + kAccA + kAccF + ncoef,
                            d_vs + 3 * (v - begin));
      lbs_shape_backward_range(m, f, int64_t(3) * begin, int64_t(3) * end, d_vs, a + kAccA + kAccF);
    };
    if (chunks >= kMinParallelChunks)
      parallel_for(chunks, run);
    else
      for (int64_t ch = 0; ch < chunks; ++ch) run(ch);
    for (int64_t ch = 1; ch < chunks; ++ch) {
      const T* src = acc.data() + size_t(ch) * acc_size;
      for (int i = 0; i < acc_size; ++i) acc[i] += src[i];
    }
  } else {
    acc.assign(acc_size, T(0));
  }
  lbs_frame_backward(d, p, c, acc.data(), d_joints, grad);
}

template <class T>
SmplxGrad<T> Lbs<T>::make_grad(const SmplxView<T>& p) const {
  SmplxGrad<T> g;
  g.betas.assign(p.num_betas, T(0));
  g.expression.assign(p.num_expr, T(0));
  return g;
}

namespace {
// SmplxParams (float) as a scalar-T view; owns the converted copies.
template <class T>
struct ParamsAs {
  std::array<T, kNumPoseValues> pose;
  std::vector<T> betas, expression;
  std::array<T, 3> transl;
  explicit ParamsAs(const SmplxParams& p)
      : betas(p.betas.begin(), p.betas.end()), expression(p.expression.begin(), p.expression.end()) {
    for (int i = 0; i < kNumPoseValues; ++i) pose[i] = T(p.pose[i]);
    for (int i = 0; i < 3; ++i) transl[i] = T(p.transl[i]);
  }
  SmplxView<T> view() const {
    return {pose.data(), betas.data(), int(betas.size()), expression.data(), int(expression.size()), transl.data()};
  }
};
}  // namespace

template <class T>
void Lbs<T>::forward(const SmplxParams& p, T* verts, T* joints, LbsCache<T>* cache) const {
  const ParamsAs<T> q(p);
  forward(q.view(), verts, joints, cache);
}

template <class T>
void Lbs<T>::backward(const SmplxParams& p, const LbsCache<T>& cache, const T* d_verts, const T* d_joints,
                      SmplxGrad<T>& grad) const {
  const ParamsAs<T> q(p);
  backward(q.view(), cache, d_verts, d_joints, grad);
}

template <class T>
SmplxGrad<T> Lbs<T>::make_grad(const SmplxParams& p) const {
  SmplxGrad<T> g;
  g.betas.assign(p.betas.size(), T(0));
  g.expression.assign(p.expression.size(), T(0));
  return g;
}

template <class T>
void Lbs<T>::forward_frames(const std::vector<SmplxParams>& frames, T* verts, T* joints) const {
  for (size_t i = 0; i < frames.size(); ++i)
    forward(frames[i], verts + i * size_t(num_verts_) * 3, joints ? joints + i * size_t(kJ) * 3 : nullptr, nullptr);
}

#define HAHA_LBS_INSTANTIATE(T)                                                                                 \
  template class Lbs<T>;                                                                                       \
  template LbsModelData<T> lbs_model_data<T>(const BodyModel&);                                               \
  template void lbs_frame_forward<T>(const LbsModelData<T>&, const SmplxView<T>&, LbsCache<T>&, T*,           \
                                     const std::string&);                                                      \
  template void lbs_skinning_matrices<T>(const LbsCache<T>&, T*);                                              \
  template void lbs_frame_backward<T>(const LbsModelData<T>&, const SmplxView<T>&, const LbsCache<T>&, const T*, \
                                      const T*, SmplxGrad<T>&);
HAHA_LBS_INSTANTIATE(float)
HAHA_LBS_INSTANTIATE(double)
#undef HAHA_LBS_INSTANTIATE

}  // namespace haha
