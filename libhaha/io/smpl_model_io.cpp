// SMPL model .npz reading / writing in the 55-joint layout (io/smpl_model_io.h).
#include "io/smpl_model_io.h"

#include <cmath>

#include "core/error.h"
#include "io/npy.h"

namespace haha {

namespace {

constexpr int kSmplParents[kSmplJoints] = {-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};

std::vector<float> finite_floats(const Npz& z, const std::string& key, const std::vector<int64_t>& shape) {
  std::vector<float> v;
  for (double x : npz_numbers(z, key, shape)) v.push_back(float(x));  // npz_numbers rejects non-finite
  return v;
}

}  // namespace

BodyModel load_smpl_model(const std::string& path) {
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".pkl") == 0)
    fail(path, "SMPL .pkl files hold chumpy/scipy objects that are not read: convert it to .npz (numpy arrays "
               "v_template, f, J_regressor (dense), kintree_table, weights, shapedirs, posedirs)");
  const Npz z = Npz::read(path);
  BodyModel m;
  m.source = path;
  const int64_t V = z.get("v_template", {-1, 3}).shape[0];
  if (V <= 0) fail(path + ": v_template", "no vertices");
  m.num_verts = int(V);
  m.v_template = finite_floats(z, "v_template", {V, 3});
  const int64_t F = z.get("f", {-1, 3}).shape[0];
  if (F <= 0) fail(path + ": f", "no faces");
  m.num_faces = int(F);
  for (double x : npz_numbers(z, "f", {F, 3})) {
    if (x < 0 || x >= double(V) || x != std::floor(x)) fail(path + ": f", "vertex index " + std::to_string(x) + " outside the model");
    m.faces.push_back(int32_t(x));
  }
  const NpyArray& jr = z.get("J_regressor");
  if (jr.ndim() == 2 && jr.shape[0] == kNumJoints)
    fail(path + ": J_regressor", "has 55 rows: this is an SMPL-X model, --smpl-model needs SMPL (24 joints)");
  const std::vector<float> J = finite_floats(z, "J_regressor", {kSmplJoints, V});
  const std::vector<float> W = finite_floats(z, "weights", {V, kSmplJoints});
  const std::vector<double> kt = npz_numbers(z, "kintree_table", {2, kSmplJoints});
  for (int j = 1; j < kSmplJoints; ++j)
    if (kt[size_t(j)] != kSmplParents[j])
      fail(path + ": kintree_table", "joint " + std::to_string(j) + " has parent " + std::to_string(kt[size_t(j)]) +
                                         ", SMPL's is " + std::to_string(kSmplParents[j]));
  // The 55-joint parents (SMPL-X's); slots 25 and 40 are wrist children there as well.
  const int smplx_parents[kNumJoints] = {-1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,  9,  12, 13, 14, 16,
                                         17, 18, 19, 15, 15, 15, 20, 25, 26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20,
                                         37, 38, 21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};
  m.parents.assign(smplx_parents, smplx_parents + kNumJoints);
  m.j_regressor.assign(size_t(kNumJoints) * size_t(V), 0.0f);
  m.weights.assign(size_t(V) * kNumJoints, 0.0f);
  for (int j = 0; j < kSmplJoints; ++j) {
    const int s = kSmplJointSlot[j];
    for (int64_t v = 0; v < V; ++v) {
      m.j_regressor[size_t(s) * size_t(V) + size_t(v)] = J[size_t(j) * size_t(V) + size_t(v)];
      m.weights[size_t(v) * kNumJoints + size_t(s)] = W[size_t(v) * kSmplJoints + size_t(j)];
    }
  }
  const int64_t S = z.get("shapedirs", {V, 3, -1}).shape[2];
  if (S < 1 || S > 300) fail(path + ": shapedirs", std::to_string(S) + " shape columns, expected 10 to 300");
  m.num_shape = int(S);
  m.num_expr = 0;
  m.shapedirs = finite_floats(z, "shapedirs", {V, 3, S});
  if (z.has("posedirs")) {
    const std::vector<float> P = finite_floats(z, "posedirs", {V, 3, 9 * (kSmplJoints - 1)});
    m.posedirs.assign(size_t(V) * 3 * kNumPoseFeatures, 0.0f);
    for (int64_t r = 0; r < V * 3; ++r)
      for (int j = 1; j < kSmplJoints; ++j)
        for (int k = 0; k < 9; ++k)
          m.posedirs[size_t(r) * kNumPoseFeatures + size_t(9 * (kSmplJointSlot[j] - 1) + k)] =
              P[size_t(r) * 207 + size_t(9 * (j - 1) + k)];
  }
  return m;
}

void save_smpl_model(const BodyModel& m, const std::string& path) {
  const int64_t V = m.num_verts, F = m.num_faces;
  std::vector<bool> used(kNumJoints, false);
  for (int s : kSmplJointSlot) used[size_t(s)] = true;
  std::vector<float> J(size_t(kSmplJoints) * size_t(V)), W(size_t(V) * kSmplJoints);
  for (int64_t v = 0; v < V; ++v)
    for (int s = 0; s < kNumJoints; ++s)
      if (!used[size_t(s)] && m.weights[size_t(v) * kNumJoints + size_t(s)] != 0.0f)
        fail(path, "vertex " + std::to_string(v) + " is skinned to joint " + std::to_string(s) + ", which SMPL lacks");
  for (int j = 0; j < kSmplJoints; ++j)
    for (int64_t v = 0; v < V; ++v) {
      J[size_t(j) * size_t(V) + size_t(v)] = m.j_regressor[size_t(kSmplJointSlot[j]) * size_t(V) + size_t(v)];
      W[size_t(v) * kSmplJoints + size_t(j)] = m.weights[size_t(v) * kNumJoints + size_t(kSmplJointSlot[j])];
    }
  Npz z(path);
  z.set("v_template", NpyArray::from(m.v_template, {V, 3}));
  z.set("f", NpyArray::from(m.faces, {F, 3}));
  z.set("J_regressor", NpyArray::from(J, {kSmplJoints, V}));
  z.set("weights", NpyArray::from(W, {V, kSmplJoints}));
  std::vector<int64_t> kt(2 * kSmplJoints);
  for (int j = 0; j < kSmplJoints; ++j) kt[size_t(j)] = kSmplParents[j], kt[size_t(kSmplJoints + j)] = j;
  z.set("kintree_table", NpyArray::from(kt, {2, kSmplJoints}));
  const int S_in = m.num_shape + m.num_expr;
  std::vector<float> sd(size_t(V) * 3 * size_t(m.num_shape));
  for (int64_t r = 0; r < V * 3; ++r)
    for (int k = 0; k < m.num_shape; ++k) sd[size_t(r) * size_t(m.num_shape) + size_t(k)] = m.shapedirs[size_t(r) * size_t(S_in) + size_t(k)];
  z.set("shapedirs", NpyArray::from(sd, {V, 3, m.num_shape}));
  if (!m.posedirs.empty()) {
    std::vector<float> P(size_t(V) * 3 * 207);
    for (int64_t r = 0; r < V * 3; ++r)
      for (int j = 1; j < kSmplJoints; ++j)
        for (int k = 0; k < 9; ++k)
          P[size_t(r) * 207 + size_t(9 * (j - 1) + k)] =
              m.posedirs[size_t(r) * kNumPoseFeatures + size_t(9 * (kSmplJointSlot[j] - 1) + k)];
    z.set("posedirs", NpyArray::from(P, {V, 3, 207}));
  }
  z.write(path);
}

SmplxParams smpl_params(const double* pose72, const std::vector<float>& betas, const double* transl) {
  SmplxParams p;
  for (int j = 0; j < kSmplJoints; ++j)
    for (int c = 0; c < 3; ++c) p.pose[size_t(3 * kSmplJointSlot[j] + c)] = float(pose72[3 * j + c]);
  p.betas = betas;
  for (int c = 0; c < 3; ++c) p.transl[size_t(c)] = float(transl[c]);
  return p;
}

}  // namespace haha
