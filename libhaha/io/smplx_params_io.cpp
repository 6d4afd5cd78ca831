// SMPL-X parameter files: one or N frames of fits / motions.
#include "io/smplx_params_io.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/npy.h"

namespace haha {
namespace {

struct PoseKey {
  const char* name;
  int first_joint;
  int joints;
};
// global_orient | body | jaw | leye | reye | left hand | right hand (docs/method.md section 5)
constexpr PoseKey kPoseKeys[] = {
    {"global_orient", kGlobalOrient, 1}, {"body_pose", kBodyFirst, 21},
    {"jaw_pose", kJaw, 1},               {"leye_pose", kLeftEye, 1},
    {"reye_pose", kRightEye, 1},         {"left_hand_pose", kLeftHandFirst, 15},
    {"right_hand_pose", kRightHandFirst, 15},
};

// One key as rows x width doubles; 1-D arrays are one row.
struct Table {
  bool present = false;
  int64_t rows = 0, width = 0;
  std::vector<double> v;
  const double* row(int64_t i) const { return v.data() + (rows == 1 ? 0 : i) * width; }
};

Table read_table(const Npz& z, const std::string& key) {
  Table t;
  if (!z.has(key)) {
    const std::vector<std::string> keys = z.keys();
    // Listed but undecodable (object array, unsupported dtype): get() names the reason.
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) z.get(key);
    return t;  // absent: zeros
  }
  const NpyArray& a = z.get(key);
  const std::string where = z.path() + ": " + key;
  if (a.ndim() == 1) {
    t.rows = 1;
    t.width = a.shape[0];
  } else if (a.ndim() == 2) {
    t.rows = a.shape[0];
    t.width = a.shape[1];
  } else {
    fail(where, "wrong shape " + shape_string(a.shape) + ", expected (D,) or (N, D)");
  }
  if (t.rows == 0) fail(where, "wrong shape " + shape_string(a.shape) + ": no frames");
  try {
    t.v = a.as_double();
  } catch (const Error& e) {
    fail(where, e.what());
  }
  for (size_t i = 0; i < t.v.size(); ++i)
    if (!std::isfinite(t.v[i]))
      fail(where, "non-finite value in frame " + std::to_string(t.width ? int64_t(i) / t.width : 0));
  t.present = true;
  return t;
}

}  // namespace

std::vector<SmplxParams> read_smplx_params(const std::string& path, const BodyModel* model, bool flat_hand_mean) {
  const Npz z = Npz::read(path);
  auto bad = [&](const std::string& key, const std::string& what) { fail(path + ": " + key, what); };

  Table pose[7];
  for (int i = 0; i < 7; ++i) pose[i] = read_table(z, kPoseKeys[i].name);
  const Table betas = read_table(z, "betas");
  const Table expr = read_table(z, "expression");
  const Table transl = read_table(z, "transl");

  // Frame count: the largest row count; others must match, betas / expression may be
  // shared (one row).
  int64_t n = 0;
  bool any = false;
  auto count = [&](const Table& t) {
    if (t.present) n = std::max(n, t.rows), any = true;
  };
  for (const Table& t : pose) count(t);
  count(betas);
  count(expr);
  count(transl);
  if (!any)
    fail(path, "no SMPL-X parameter arrays (global_orient, body_pose, jaw_pose, leye_pose, reye_pose, "
               "left_hand_pose, right_hand_pose, betas, expression, transl)");
  auto frames_ok = [&](const Table& t, const std::string& key, bool shared_ok) {
    if (t.present && t.rows != n && !(shared_ok && t.rows == 1))
      bad(key, "has " + std::to_string(t.rows) + " frames, other arrays have " + std::to_string(n));
  };

  // Widths.
  for (int i = 0; i < 7; ++i) {
    const Table& t = pose[i];
    const PoseKey& k = kPoseKeys[i];
    frames_ok(t, k.name, false);
    if (!t.present) continue;
    const int64_t full = 3 * k.joints;
    const bool hand = k.joints == 15;
    const bool smpl_body = k.first_joint == kBodyFirst && t.width == 69;  // SMPL: 23 joints, first 21 shared
    if (t.width == full || smpl_body) continue;
    if (hand && t.width >= 1 && t.width < 45) {
      const auto& comp = k.first_joint == kLeftHandFirst ? (model ? &model->hands_components_l : nullptr)
                                                         : (model ? &model->hands_components_r : nullptr);
      if (!comp || comp->size() != 45 * 45)
        bad(k.name, std::to_string(t.width) + " PCA coefficients need the body model's hand components");
      continue;
    }
    bad(k.name, "has " + std::to_string(t.width) + " values per frame, expected " + std::to_string(full) +
                    (hand ? " (axis-angle) or 1..44 (PCA)" : ""));
  }
  frames_ok(betas, "betas", true);
  frames_ok(expr, "expression", true);
  frames_ok(transl, "transl", false);
  if (transl.present && transl.width != 3)
    bad("transl", "has " + std::to_string(transl.width) + " values per frame, expected 3");
  if (model && betas.present && betas.width > model->num_shape)
    bad("betas", std::to_string(betas.width) + " values, the body model has " + std::to_string(model->num_shape) +
                     " shape components");
  if (model && expr.present && expr.width > model->num_expr)
    bad("expression", std::to_string(expr.width) + " values, the body model has " + std::to_string(model->num_expr) +
                          " expression components");
  if (!flat_hand_mean && (!model || model->hands_mean_l.size() != 45 || model->hands_mean_r.size() != 45))
    fail(path, "a non-flat hand mean needs the body model's hands_meanl / hands_meanr");

  std::vector<SmplxParams> out(static_cast<size_t>(n));
  for (int64_t f = 0; f < n; ++f) {
    SmplxParams& p = out[size_t(f)];
    for (int i = 0; i < 7; ++i) {
      const Table& t = pose[i];
      const PoseKey& k = kPoseKeys[i];
      float* dst = p.pose.data() + 3 * k.first_joint;
      if (t.present) {
        const double* src = t.row(f);
        if (t.width == 3 * k.joints || t.width == 69) {
          for (int c = 0; c < 3 * k.joints; ++c) dst[c] = float(src[c]);
        } else {  // PCA: pose = sum_i c_i components[i, :]
          const std::vector<float>& comp =
              k.first_joint == kLeftHandFirst ? model->hands_components_l : model->hands_components_r;
          for (int c = 0; c < 45; ++c) {
            double acc = 0;
            for (int64_t q = 0; q < t.width; ++q) acc += src[q] * comp[size_t(q) * 45 + c];
            dst[c] = float(acc);
          }
        }
      }
      if (k.joints == 15 && !flat_hand_mean) {
        const std::vector<float>& mean = k.first_joint == kLeftHandFirst ? model->hands_mean_l : model->hands_mean_r;
        for (int c = 0; c < 45; ++c) dst[c] += mean[c];
      }
    }
    if (betas.present) p.betas.assign(betas.row(f), betas.row(f) + betas.width);
    if (expr.present) p.expression.assign(expr.row(f), expr.row(f) + expr.width);
    if (transl.present)
      for (int c = 0; c < 3; ++c) p.transl[c] = float(transl.row(f)[c]);
  }
  return out;
}

void write_smplx_params(const std::string& path, const std::vector<SmplxParams>& frames) {
  if (frames.empty()) fail(path, "no frames to write");
  const int64_t n = int64_t(frames.size());
  auto finite = [](const float* v, size_t k) {
    for (size_t i = 0; i < k; ++i)
      if (!std::isfinite(v[i])) return false;
    return true;
  };
  for (int64_t f = 0; f < n; ++f) {
    const SmplxParams& p = frames[size_t(f)];
    if (!finite(p.pose.data(), p.pose.size()) || !finite(p.betas.data(), p.betas.size()) ||
        !finite(p.expression.data(), p.expression.size()) || !finite(p.transl.data(), 3))
      fail(path, "frame " + std::to_string(f) + ": non-finite parameter value");
  }
  Npz z(path);
  for (const PoseKey& k : kPoseKeys) {
    const int w = 3 * k.joints;
    std::vector<float> v(size_t(n) * w);
    for (int64_t f = 0; f < n; ++f)
      std::copy_n(frames[size_t(f)].pose.data() + 3 * k.first_joint, w, v.data() + f * w);
    z.set(k.name, NpyArray::from(v, {n, w}));
  }
  // betas / expression: frames may differ in length; shorter ones are zero-padded (the
  // missing values mean zero anyway).
  auto ragged = [&](const char* key, auto member) {
    size_t w = 0;
    for (const SmplxParams& p : frames) w = std::max(w, (p.*member).size());
    if (w == 0) return;
    std::vector<float> v(size_t(n) * w, 0.0f);
    for (int64_t f = 0; f < n; ++f) {
      const std::vector<float>& src = frames[size_t(f)].*member;
      std::copy(src.begin(), src.end(), v.begin() + f * int64_t(w));
    }
    z.set(key, NpyArray::from(v, {n, int64_t(w)}));
  };
  ragged("betas", &SmplxParams::betas);
  ragged("expression", &SmplxParams::expression);
  std::vector<float> t(size_t(n) * 3);
  for (int64_t f = 0; f < n; ++f) std::copy_n(frames[size_t(f)].transl.data(), 3, t.data() + f * 3);
  z.set("transl", NpyArray::from(t, {n, 3}));
  z.write(path);
}

}  // namespace haha
