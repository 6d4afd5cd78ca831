// SMPL-X model .npz reading / writing (layout: docs/method.md section 5).
#include "io/body_model_io.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/npy.h"

namespace haha {
namespace {

constexpr int kJ = kNumJoints;

// Reads arrays of one archive; every error is "file: key: problem".
class ModelReader {
 public:
  explicit ModelReader(const Npz& z) : z_(z) {}

  [[noreturn]] void bad(const std::string& key, const std::string& what) const { fail(z_.path() + ": " + key, what); }

  bool has(const std::string& key) const { return z_.has(key); }
  const NpyArray& get(const std::string& key, const std::vector<int64_t>& shape) const { return z_.get(key, shape); }

  // Numeric array as float, rejecting NaN/Inf (also values that overflow float).
  std::vector<float> floats(const std::string& key, const std::vector<int64_t>& shape) const {
    const NpyArray& a = get(key, shape);
    std::vector<float> v;
    try {
      v = a.as_float();
    } catch (const Error& e) {
      bad(key, e.what());
    }
    for (size_t i = 0; i < v.size(); ++i)
      if (!std::isfinite(v[i])) bad(key, "non-finite value at flat index " + std::to_string(i));
    return v;
  }

  // Integer array (any stored integer width), values checked against [lo, hi).
  std::vector<int32_t> ints(const std::string& key, const std::vector<int64_t>& shape, int64_t lo, int64_t hi) const {
    const NpyArray& a = get(key, shape);
    if (a.dtype == DType::f32 || a.dtype == DType::f64) bad(key, "expected integers, got '" + a.descr + "'");
    std::vector<int32_t> v;
    try {
      v = a.as_int32();
    } catch (const Error& e) {
      bad(key, e.what());
    }
    for (size_t i = 0; i < v.size(); ++i)
      if (v[i] < lo || v[i] >= hi)
        bad(key, "index " + std::to_string(v[i]) + " at flat position " + std::to_string(i) + " outside [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + ")");
    return v;
  }

  // Two optional keys that only make sense together.
  bool pair_present(const std::string& a, const std::string& b) const {
    if (has(a) != has(b)) bad(has(a) ? b : a, "missing (needed together with '" + (has(a) ? a : b) + "')");
    return has(a);
  }

 private:
  const Npz& z_;
};

}  // namespace

BodyModel load_body_model(const std::string& path) {
  const Npz z = Npz::read(path);
  const ModelReader r(z);
  BodyModel m;
  m.source = path;

  const NpyArray& vt = r.get("v_template", {-1, 3});
  const int64_t V = vt.shape[0];
  if (V <= 0) r.bad("v_template", "no vertices");
  m.num_verts = int(V);
  m.v_template = r.floats("v_template", {V, 3});

  const int64_t F = r.get("f", {-1, 3}).shape[0];
  if (F <= 0) r.bad("f", "no faces");
  m.num_faces = int(F);
  m.faces = r.ints("f", {F, 3}, 0, V);

  // `joints_rest` (55, 3), this project's own key: the fixed rest joints of a body whose
  // shape is baked (an unpacked avatar); then J_regressor may be absent.
  if (r.has("joints_rest")) m.joints_rest = r.floats("joints_rest", {kJ, 3});
  if (m.joints_rest.empty() || r.has("J_regressor")) m.j_regressor = r.floats("J_regressor", {kJ, V});
  m.weights = r.floats("weights", {V, kJ});

  // kintree_table row 0 = parents. parents[0] is stored as -1, 2^32-1 or anything: it
  // is the root. Read as double so every integer width (and uint32 2^32-1) passes.
  {
    const NpyArray& kt = r.get("kintree_table", {2, kJ});
    std::vector<double> v;
    try {
      v = kt.as_double();
    } catch (const Error& e) {
      r.bad("kintree_table", e.what());
    }
    m.parents.assign(kJ, -1);
    for (int j = 1; j < kJ; ++j) {
      const double p = v[j];
      if (!(p >= 0 && p < j) || p != std::floor(p))
        r.bad("kintree_table", "joint " + std::to_string(j) + " has parent " + std::to_string(p) +
                                   " (expected an earlier joint index)");
      m.parents[j] = int32_t(p);
    }
  }

  // shapedirs: 400 columns = 300 shape + 100 expression (SMPL-X 1.1), 20 = 10 + 10 (1.0).
  {
    const int64_t S = r.get("shapedirs", {V, 3, -1}).shape[2];
    if (S == 400) {
      m.num_shape = 300;
      m.num_expr = 100;
    } else if (S == 20) {
      m.num_shape = 10;
      m.num_expr = 10;
    } else {
      r.bad("shapedirs", "has " + std::to_string(S) + " columns, expected 400 (300 shape + 100 expression) or 20 (10 + 10)");
    }
    m.shapedirs = r.floats("shapedirs", {V, 3, S});
  }
  // Pose correctives: optional (absent = none), else (V, 3, 486).
  if (r.has("posedirs")) m.posedirs = r.floats("posedirs", {V, 3, kNumPoseFeatures});

  if (r.has("hands_componentsl")) m.hands_components_l = r.floats("hands_componentsl", {45, 45});
  if (r.has("hands_componentsr")) m.hands_components_r = r.floats("hands_componentsr", {45, 45});
  if (r.has("hands_meanl")) m.hands_mean_l = r.floats("hands_meanl", {45});
  if (r.has("hands_meanr")) m.hands_mean_r = r.floats("hands_meanr", {45});

  if (r.pair_present("lmk_faces_idx", "lmk_bary_coords")) {
    const int64_t L = r.get("lmk_faces_idx", {-1}).shape[0];
    m.lmk_faces_idx = r.ints("lmk_faces_idx", {L}, 0, F);
    m.lmk_bary_coords = r.floats("lmk_bary_coords", {L, 3});
  }
  if (r.pair_present("vt", "ft")) {
    const int64_t T = r.get("vt", {-1, 2}).shape[0];
    m.vt = r.floats("vt", {T, 2});
    m.ft = r.ints("ft", {F, 3}, 0, T);
  }
  return m;
}

void save_body_model(const BodyModel& m, const std::string& path) {
  const int64_t V = m.num_verts, F = m.num_faces;
  auto need = [&](const char* key, size_t got, size_t want) {
    if (got != want)
      fail(path + ": " + key, "model holds " + std::to_string(got) + " values, expected " + std::to_string(want));
  };
  need("v_template", m.v_template.size(), size_t(V) * 3);
  need("f", m.faces.size(), size_t(F) * 3);
  if (m.joints_rest.empty() || !m.j_regressor.empty()) need("J_regressor", m.j_regressor.size(), size_t(kJ) * V);
  if (!m.joints_rest.empty()) need("joints_rest", m.joints_rest.size(), size_t(kJ) * 3);
  need("weights", m.weights.size(), size_t(V) * kJ);
  need("kintree_table", m.parents.size(), kJ);
  need("shapedirs", m.shapedirs.size(), size_t(V) * 3 * (m.num_shape + m.num_expr));

  Npz z(path);
  z.set("v_template", NpyArray::from(m.v_template, {V, 3}));
  z.set("f", NpyArray::from(m.faces, {F, 3}));
  if (!m.j_regressor.empty()) z.set("J_regressor", NpyArray::from(m.j_regressor, {kJ, V}));
  if (!m.joints_rest.empty()) z.set("joints_rest", NpyArray::from(m.joints_rest, {kJ, 3}));
  z.set("weights", NpyArray::from(m.weights, {V, kJ}));
  std::vector<int64_t> kt(2 * kJ);
  for (int j = 0; j < kJ; ++j) {
    kt[j] = j == 0 ? -1 : m.parents[j];
    kt[kJ + j] = j;
  }
  z.set("kintree_table", NpyArray::from(kt, {2, kJ}));

  // The file layout knows two column splits; smaller models are zero-padded to one.
  int ns, ne;
  if (m.num_shape <= 10 && m.num_expr <= 10) {
    ns = 10, ne = 10;
  } else if (m.num_shape <= 300 && m.num_expr <= 100) {
    ns = 300, ne = 100;
  } else {
    fail(path + ": shapedirs", std::to_string(m.num_shape) + " shape + " + std::to_string(m.num_expr) +
                                   " expression columns do not fit the SMPL-X layout (300 + 100)");
  }
  const int S_in = m.num_shape + m.num_expr, S = ns + ne;
  std::vector<float> sd(size_t(V) * 3 * S, 0.0f);
  for (int64_t row = 0; row < V * 3; ++row) {
    const float* src = m.shapedirs.data() + row * S_in;
    float* dst = sd.data() + row * S;
    for (int k = 0; k < m.num_shape; ++k) dst[k] = src[k];
    for (int k = 0; k < m.num_expr; ++k) dst[ns + k] = src[m.num_shape + k];
  }
  z.set("shapedirs", NpyArray::from(sd, {V, 3, S}));
  if (!m.posedirs.empty()) {
    need("posedirs", m.posedirs.size(), size_t(V) * 3 * kNumPoseFeatures);
    z.set("posedirs", NpyArray::from(m.posedirs, {V, 3, kNumPoseFeatures}));
  }
  auto optional = [&](const char* key, const std::vector<float>& v, std::vector<int64_t> shape) {
    if (v.empty()) return;
    int64_t n = 1;
    for (int64_t d : shape) n *= d;
    need(key, v.size(), size_t(n));
    z.set(key, NpyArray::from(v, std::move(shape)));
  };
  optional("hands_componentsl", m.hands_components_l, {45, 45});
  optional("hands_componentsr", m.hands_components_r, {45, 45});
  optional("hands_meanl", m.hands_mean_l, {45});
  optional("hands_meanr", m.hands_mean_r, {45});
  if (!m.lmk_faces_idx.empty()) {
    const int64_t L = int64_t(m.lmk_faces_idx.size());
    z.set("lmk_faces_idx", NpyArray::from(m.lmk_faces_idx, {L}));
    need("lmk_bary_coords", m.lmk_bary_coords.size(), size_t(L) * 3);
    z.set("lmk_bary_coords", NpyArray::from(m.lmk_bary_coords, {L, 3}));
  }
  if (!m.vt.empty()) {
    if (m.vt.size() % 2) fail(path + ": vt", "odd number of values");
    z.set("vt", NpyArray::from(m.vt, {int64_t(m.vt.size() / 2), 2}));
    need("ft", m.ft.size(), size_t(F) * 3);
    z.set("ft", NpyArray::from(m.ft, {F, 3}));
  }
  z.write(path);
}

}  // namespace haha
