// SMPL-X linear blend skinning, forward and hand-written backward, for float (training,
// rendering) and double (finite-difference tests). Batch over frames = call per frame
// (frames are independent; parallel_for inside parallelises over vertices).
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "core/math.h"

namespace haha {

// Non-owning view of one frame's parameters in the scalar type T (SmplxParams is float;
// double views drive the finite-difference tests). Only the betas / expression values
// given are used (the other model columns count as zero): num_betas <= model num_shape,
// num_expr <= model num_expr, else forward throws.
template <class T>
struct SmplxView {
  const T* pose = nullptr;        // (165) axis-angle, layout of SmplxParams::pose
  const T* betas = nullptr;       // (num_betas)
  int num_betas = 0;
  const T* expression = nullptr;  // (num_expr)
  int num_expr = 0;
  const T* transl = nullptr;      // (3); null = zero
};

template <class T>
struct SmplxGrad {
  std::array<T, kNumPoseValues> pose{};
  std::vector<T> betas, expression;  // same lengths as the params' vectors
  std::array<T, 3> transl{};
};

// Intermediates of one forward pass that the backward pass reuses.
template <class T>
struct LbsCache {
  std::vector<T> v_shaped;            // (V, 3)
  std::vector<T> v_posed;             // (V, 3) shaped + pose correctives
  std::vector<T> joints_rest;         // (55, 3) J_regressor * v_shaped
  std::vector<Mat3<T>> local_rot;     // (55) Rodrigues of each joint's axis-angle
  std::vector<Rigid<T>> world;        // (55) chained joint transforms G_j
  std::vector<Rigid<T>> skinning;     // (55) A_j = G_j with rest joint removed
  std::vector<T> pose_feature;        // (486) (R_j - I) entries
};

template <class T>
class Lbs {
 public:
  explicit Lbs(const BodyModel& model);  // converts and precomputes (sparse weights etc.)

  // verts: (V, 3) posed vertices + transl. joints: (55, 3) posed joints + transl (may be null).
  void forward(const SmplxParams& p, T* verts, T* joints, LbsCache<T>* cache) const;
  // Adds dL/dparams for dL/dverts (V,3) and dL/djoints (55,3, may be null) into grad
  // (grad must be sized: call SmplxGrad resize via make_grad()).
  void backward(const SmplxParams& p, const LbsCache<T>& cache, const T* d_verts, const T* d_joints,
                SmplxGrad<T>& grad) const;
  SmplxGrad<T> make_grad(const SmplxParams& p) const;

  // The same on a scalar-T view (identical maths; the SmplxParams overloads convert).
  void forward(const SmplxView<T>& p, T* verts, T* joints, LbsCache<T>* cache) const;
  void backward(const SmplxView<T>& p, const LbsCache<T>& cache, const T* d_verts, const T* d_joints,
                SmplxGrad<T>& grad) const;
  SmplxGrad<T> make_grad(const SmplxView<T>& p) const;

  // Batch over frames: verts (N, V, 3), joints (N, 55, 3) or null. Frames run one after
  // another, each parallel over vertices.
  void forward_frames(const std::vector<SmplxParams>& frames, T* verts, T* joints) const;

  int num_verts() const { return num_verts_; }
  const BodyModel& model() const { return *model_; }

 private:
  const BodyModel* model_;
  int num_verts_ = 0;
  // Implementation-defined precomputed data (converted arrays, sparse skinning weights,
  // regressor rows) lives here.
  struct Data;
  std::shared_ptr<const Data> data_;
};

extern template class Lbs<float>;
extern template class Lbs<double>;

}  // namespace haha
