#include "cuda/lbs_cuda.h"

#include <vector>

#include "cuda/device_util.cuh"

namespace haha::cuda {

namespace {

using detail::AtomicAdd;

__global__ void lbs_forward_kernel(LbsModelView<float> m, LbsFrameView<float> f, float* vs, float* verts,
                                   float* v_posed) {
  const int v = int(detail::global_index());
  if (v >= m.V) return;
  // The shape pass of this vertex's three rows: consecutive threads read consecutive
  // values of each shape column (coalesced).
  lbs_shape_range(m, f, int64_t(3) * v, int64_t(3) * v + 3, vs);
  lbs_vertex_forward(m, f, v, vs, verts, v_posed);
}

__global__ void lbs_backward_kernel(LbsModelView<float> m, LbsFrameView<float> f, const float* v_posed,
                                    const float* d_verts, float* acc) {
  extern __shared__ float sacc[];
  const int ncoef = f.nb + f.ne;
  const int size = lbs_acc_size(ncoef);
  for (int i = threadIdx.x; i < size; i += blockDim.x) sacc[i] = 0.0f;
  __syncthreads();
  const int v = int(detail::global_index());
  if (v < m.V) {
    float d_vs[3];
    lbs_vertex_backward(m, f, v, v_posed, d_verts, sacc, sacc + kLbsAccA, sacc + kLbsAccA + kLbsAccF + ncoef, d_vs,
                        AtomicAdd{});
    // A vertex without gradient adds exact zeros; skip its ncoef atomics.
    if (d_vs[0] != 0.0f || d_vs[1] != 0.0f || d_vs[2] != 0.0f)
      lbs_shape_backward_range(m, f, int64_t(3) * v, int64_t(3) * v + 3, d_vs, sacc + kLbsAccA + kLbsAccF,
                               AtomicAdd{});
  }
  __syncthreads();
  for (int i = threadIdx.x; i < size; i += blockDim.x)
    if (sacc[i] != 0.0f) atomicAdd(&acc[i], sacc[i]);
}

}  // namespace

LbsCuda::LbsCuda(const BodyModel& model)
    : host_(lbs_model_data<float>(model)), where_(model.source.empty() ? std::string("body model") : model.source) {
  v_template_.upload(host_.v_template);
  shapedirs_.upload(host_.shapedirs);
  w_val_.upload(host_.w_val);
  p_data_.upload(host_.p_data);
  w_off_.upload(host_.w_off);
  w_joint_.upload(host_.w_joint);
  p_off_.upload(host_.p_off);
  p_feat_.upload(host_.p_feat);
  v_shaped_.resize(size_t(host_.V) * 3);
}

LbsModelView<float> LbsCuda::device_view() const {
  return {host_.V,         host_.S,       host_.num_shape, v_template_.data(), shapedirs_.data(), w_off_.data(),
          w_joint_.data(), w_val_.data(), p_off_.data(),   p_feat_.data(),     p_data_.data()};
}

void LbsCuda::upload_frame(const SmplxView<float>& p, const LbsCache<float>& chain, LbsFrameView<float>& f) {
  const int nb = p.num_betas, ne = p.num_expr;
  std::vector<float> h(size_t(nb + ne + kNumPoseFeatures + kLbsAccA));
  for (int k = 0; k < nb; ++k) h[size_t(k)] = p.betas[k];
  for (int k = 0; k < ne; ++k) h[size_t(nb + k)] = p.expression[k];
  for (int k = 0; k < kNumPoseFeatures; ++k) h[size_t(nb + ne + k)] = chain.pose_feature[size_t(k)];
  lbs_skinning_matrices(chain, h.data() + nb + ne + kNumPoseFeatures);
  frame_.upload(h);
  const float* d = frame_.data();
  f = LbsFrameView<float>{d, nb, d + nb, ne, d + nb + ne, d + nb + ne + kNumPoseFeatures, {0, 0, 0}};
  if (p.transl)
    for (int r = 0; r < 3; ++r) f.transl[r] = p.transl[r];
}

void LbsCuda::forward(const SmplxView<float>& p, float* verts, float* joints, LbsCudaCache* cache) {
  LbsCache<float> local;
  LbsCache<float>& c = cache ? cache->chain : local;
  float A[kNumJoints * 12];
  lbs_frame_forward(host_, p, c, A, where_);
  LbsFrameView<float> f;
  upload_frame(p, c, f);
  float* vp = nullptr;
  if (cache) {
    cache->v_posed.resize(size_t(host_.V) * 3);
    vp = cache->v_posed.data();
  }
  HAHA_LAUNCH(lbs_forward_kernel, host_.V, detail::kThreads, 0, device_view(), f, v_shaped_.data(), verts, vp);
  if (joints)
    for (int j = 0; j < kNumJoints; ++j)
      for (int r = 0; r < 3; ++r) joints[3 * j + r] = c.world[size_t(j)].t[r] + f.transl[r];
}

void LbsCuda::backward(const SmplxView<float>& p, const LbsCudaCache& cache, const float* d_verts,
                       const float* d_joints, SmplxGrad<float>& grad) {
  if (cache.v_posed.size() != size_t(host_.V) * 3 || cache.chain.world.size() != size_t(kNumJoints))
    fail(where_, "LBS backward: cache was not filled by forward()");
  if (grad.betas.size() < size_t(p.num_betas) || grad.expression.size() < size_t(p.num_expr))
    fail(where_, "LBS backward: gradient not sized for the parameters (use make_grad)");
  const int size = lbs_acc_size(p.num_betas + p.num_expr);
  std::vector<float> acc;
  if (d_verts) {
    LbsFrameView<float> f;
    upload_frame(p, cache.chain, f);
    acc_.assign_zero(size_t(size));
    HAHA_LAUNCH(lbs_backward_kernel, host_.V, detail::kThreads, size_t(size) * sizeof(float), device_view(), f,
                cache.v_posed.data(), d_verts, acc_.data());
    acc = acc_.to_host();
  }
  lbs_frame_backward(host_, p, cache.chain, acc.empty() ? nullptr : acc.data(), d_joints, grad);
}

}  // namespace haha::cuda
