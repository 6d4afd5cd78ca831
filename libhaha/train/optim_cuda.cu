#include "train/optim_cuda.h"

#include <algorithm>

#include "cuda/device_util.cuh"
#include "train/loss_kernels.h"

namespace haha::cuda {

namespace {

__global__ void adam_kernel(float* params, const float* grads, float* m, float* v, int64_t n, AdamStepCoeffs k) {
  const int64_t i = detail::global_index();
  if (i < n) adam_update(params[i], m[i], v[i], grads[i], k);
}

__global__ void gather_kernel(const float* src, int stride, const int64_t* source, int64_t n_new, float* dst,
                              float fill) {
  const int64_t e = detail::global_index();
  if (e >= n_new * stride) return;
  const int64_t row = e / stride, k = e % stride;
  const int64_t from = source[row];
  dst[e] = from >= 0 ? src[from * stride + k] : fill;
}

__global__ void knn_kernel(KnnRegInputs<float> in, const int32_t* sets, int K, KnnRegWeights w,
                           KnnRegGrads<float> g, double gs, double* sum) {
  const int64_t i = detail::global_index();
  const double v = i < in.n ? loss::knn_reg_item(in, sets, K, w, g, gs, i, detail::AtomicAdd{}) : 0.0;
  detail::block_sum_atomic(v, sum);
}

}  // namespace

void adam_step_cuda(float* params, const float* grads, float* m, float* v, int64_t n, const AdamStepCoeffs& k) {
  HAHA_LAUNCH(adam_kernel, n, detail::kThreads, 0, params, grads, m, v, n, k);
}

int AdamCuda::add_group(const std::string& name, int64_t size, double lr, int stride) {
  for (const Group& g : groups_)
    if (g.name == name) fail("adam", "group '" + name + "' registered twice");
  if (stride < 1 || size < 0 || size % stride != 0)
    fail("adam", "group '" + name + "': size " + std::to_string(size) + " is not a multiple of stride " +
                     std::to_string(stride));
  Group g;
  g.name = name;
  g.lr = lr;
  g.stride = stride;
  g.m.assign_zero(size_t(size));
  g.v.assign_zero(size_t(size));
  groups_.push_back(std::move(g));
  return int(groups_.size()) - 1;
}

int AdamCuda::group(const std::string& name) const {
  for (size_t i = 0; i < groups_.size(); ++i)
    if (groups_[i].name == name) return int(i);
  fail("adam", "no parameter group '" + name + "'");
}

void AdamCuda::step(int gi, float* params, const float* grads) {
  Group& g = groups_.at(size_t(gi));
  ++g.t;
  adam_step_cuda(params, grads, g.m.data(), g.v.data(), int64_t(g.m.size()), adam_step_coeffs(config_, g.lr, g.t));
}

void AdamCuda::load(int gi, const std::vector<float>& m, const std::vector<float>& v, int64_t t) {
  Group& g = groups_.at(size_t(gi));
  if (m.size() != v.size() || m.size() % size_t(g.stride) != 0 || t < 0)
    fail("adam", "group '" + g.name + "': state of " + std::to_string(m.size()) + " / " + std::to_string(v.size()) +
                     " values does not fit stride " + std::to_string(g.stride));
  g.m.upload(m);
  g.v.upload(v);
  g.t = t;
}

void AdamCuda::reindex(int gi, const std::vector<int64_t>& source) {
  Group& g = groups_.at(size_t(gi));
  const int64_t old_n = int64_t(g.m.size()) / g.stride;
  for (int64_t from : source)
    if (from >= old_n)
      fail("adam", "group '" + g.name + "': reindex source " + std::to_string(from) + " out of range (" +
                       std::to_string(old_n) + " elements)");
  DeviceBuffer<int64_t> src(source);
  const int64_t n_new = int64_t(source.size());
  DeviceBuffer<float> m(size_t(n_new) * g.stride), v(size_t(n_new) * g.stride);
  gather_rows_cuda(g.m.data(), g.stride, src.data(), n_new, m.data());
  gather_rows_cuda(g.v.data(), g.stride, src.data(), n_new, v.data());
  g.m = std::move(m);
  g.v = std::move(v);
  synchronize("AdamCuda::reindex");  // `src` is freed on return
}

void gather_rows_cuda(const float* src, int stride, const int64_t* source, int64_t n_new, float* dst, float fill) {
  HAHA_LAUNCH(gather_kernel, n_new * stride, detail::kThreads, 0, src, stride, source, n_new, dst, fill);
}

float knn_reg_cuda(const KnnRegInputs<float>& in, const int32_t* sets, int K, const KnnRegWeights& w,
                   const KnnRegGrads<float>* grads, float grad_scale) {
  if (in.n <= 0 || K <= 0) return 0.0f;
  DeviceBuffer<double> sum;
  sum.assign_zero(1);
  const KnnRegGrads<float> g = grads ? *grads : KnnRegGrads<float>{};
  HAHA_LAUNCH(knn_kernel, in.n, detail::kThreads, 0, in, sets, K, w, g, double(grad_scale), sum.data());
  double v = 0.0;
  sum.download(&v, 1);
  return float(v);
}

}  // namespace haha::cuda
