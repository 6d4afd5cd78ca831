// SMPL-layout stand-in of an SMPL-X model (body/smpl_standin.h).
#include "body/smpl_standin.h"

#include "body/lbs.h"
#include "core/error.h"

namespace haha {

BodyModel make_smpl_standin(const BodyModel& x, const SmplStandinOptions& opt, std::vector<int32_t>* smplx_vertex) {
  if (opt.num_shape < 1 || opt.num_shape > x.num_shape) fail("smpl stand-in", "num_shape must be in 1..source shape columns");
  const int V = x.num_verts, J = kNumJoints;
  // SMPL joint slots (io/smpl_model_io.h): 0..21, 25, 40.
  auto smpl_slot = [](int s) { return s <= 21 || s == 25 || s == 40; };
  // Where each SMPL-X joint's weight goes: jaw/eyes -> head, fingers -> the hand slot.
  auto target = [](int s) {
    if (s == kJaw || s == kLeftEye || s == kRightEye) return 15;
    if (s >= kLeftHandFirst && s < kRightHandFirst) return int(kLeftHandFirst);
    if (s >= kRightHandFirst) return int(kRightHandFirst);
    return s;
  };
  // Vertices the SMPL joints' regressor rows use are kept, and every vertex not skinned to
  // an eye.
  std::vector<int32_t> keep_index(size_t(V), -1), kept;
  for (int v = 0; v < V; ++v) {
    bool used = false, eye = false;
    for (int s = 0; s < J; ++s) {
      if (smpl_slot(s) && x.j_regressor[size_t(s) * size_t(V) + size_t(v)] != 0.0f) used = true;
      if ((s == kLeftEye || s == kRightEye) && x.weights[size_t(v) * J + size_t(s)] > 0.0f) eye = true;
    }
    if (used || !eye) keep_index[size_t(v)] = int32_t(kept.size()), kept.push_back(v);
  }
  // Shaped and shifted template: the source's rest vertices at `betas` (LBS at zero pose).
  SmplxParams rest;
  rest.betas = opt.betas;
  const Lbs<double> lbs(x);
  std::vector<double> shaped(size_t(V) * 3);
  lbs.forward(rest, shaped.data(), nullptr, nullptr);

  BodyModel m;
  m.source = "SMPL stand-in of " + x.source;
  m.num_verts = int(kept.size());
  m.num_shape = opt.num_shape;
  m.num_expr = 0;
  m.parents = x.parents;
  const size_t K = kept.size(), S_in = size_t(x.num_shape + x.num_expr);
  m.v_template.resize(K * 3);
  m.j_regressor.assign(size_t(J) * K, 0.0f);
  m.weights.assign(K * size_t(J), 0.0f);
  m.shapedirs.resize(K * 3 * size_t(opt.num_shape));
  if (!x.posedirs.empty()) m.posedirs.assign(K * 3 * kNumPoseFeatures, 0.0f);
  for (size_t k = 0; k < K; ++k) {
    const size_t v = size_t(kept[k]);
    for (int c = 0; c < 3; ++c) {
      m.v_template[3 * k + size_t(c)] = float(shaped[3 * v + size_t(c)]) + opt.shift[size_t(c)];
      for (int b = 0; b < opt.num_shape; ++b)
        m.shapedirs[(3 * k + size_t(c)) * size_t(opt.num_shape) + size_t(b)] = x.shapedirs[(3 * v + size_t(c)) * S_in + size_t(b)];
      if (!x.posedirs.empty())
        for (int s = 1; s < J; ++s)
          if (smpl_slot(s))
            for (int e = 0; e < 9; ++e) {
              const size_t col = size_t(9 * (s - 1) + e);
              m.posedirs[(3 * k + size_t(c)) * kNumPoseFeatures + col] = x.posedirs[(3 * v + size_t(c)) * kNumPoseFeatures + col];
            }
    }
    for (int s = 0; s < J; ++s) {
      m.weights[k * size_t(J) + size_t(target(s))] += x.weights[v * size_t(J) + size_t(s)];
      if (smpl_slot(s)) m.j_regressor[size_t(s) * K + k] = x.j_regressor[size_t(s) * size_t(V) + v];
    }
  }
  for (size_t f = 0; f < size_t(x.num_faces); ++f) {
    const int32_t* t = &x.faces[3 * f];
    if (keep_index[size_t(t[0])] < 0 || keep_index[size_t(t[1])] < 0 || keep_index[size_t(t[2])] < 0) continue;
    for (int c = 0; c < 3; ++c) m.faces.push_back(keep_index[size_t(t[c])]);
  }
  m.num_faces = int(m.faces.size() / 3);
  if (smplx_vertex) *smplx_vertex = kept;
  return m;
}

}  // namespace haha
