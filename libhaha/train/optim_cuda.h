// Optimiser-side work on the GPU: the Adam update (train/adam.h adam_update), an Adam with
// device moments mirroring haha::Adam's groups, the KNN regulariser over given neighbour
// sets (train/loss_kernels.h knn_reg_item) and the row gather that densification /
// pruning uses to rebuild SoA parameter arrays and moments. Pointers are device memory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "train/adam.h"
#include "train/losses.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// params[i], m[i], v[i] updated with grads[i], i < n, for the constants k
// (adam_step_coeffs).
void adam_step_cuda(float* params, const float* grads, float* m, float* v, int64_t n, const AdamStepCoeffs& k);

// haha::Adam's bookkeeping (groups, learning rates, step counts) with the moments on the
// device. step() and reindex() queue kernels; nothing is read back.
class AdamCuda {
 public:
  explicit AdamCuda(AdamConfig config = {}) : config_(config) {}
  int add_group(const std::string& name, int64_t size, double lr, int stride = 1);  // errors as Adam
  int group(const std::string& name) const;
  int num_groups() const { return int(groups_.size()); }
  int64_t size(int g) const { return int64_t(groups_.at(size_t(g)).m.size()); }
  int64_t steps(int g) const { return groups_.at(size_t(g)).t; }
  double lr(int g) const { return groups_.at(size_t(g)).lr; }
  void set_lr(int g, double lr) { groups_.at(size_t(g)).lr = lr; }
  void step(int g, float* params, const float* grads);
  // As Adam::reindex: source (host) = old element per new element, -1 = fresh moments.
  void reindex(int g, const std::vector<int64_t>& source);
  // Replaces group g's moments (host values, equal sizes, a multiple of the stride) and
  // step count: the state a host Adam hands over (train/trainer_cuda.cpp).
  void load(int g, const std::vector<float>& m, const std::vector<float>& v, int64_t t);
  std::vector<float> first_moment(int g) const { return groups_.at(size_t(g)).m.to_host(); }
  std::vector<float> second_moment(int g) const { return groups_.at(size_t(g)).v.to_host(); }

 private:
  struct Group {
    std::string name;
    double lr = 0;
    int stride = 1;
    int64_t t = 0;
    DeviceBuffer<float> m, v;
  };
  AdamConfig config_;
  std::vector<Group> groups_;
};

// dst[e * stride + k] = source[e] >= 0 ? src[source[e] * stride + k] : fill, e < n_new.
// source: device (n_new). dst must not alias src.
void gather_rows_cuda(const float* src, int stride, const int64_t* source, int64_t n_new, float* dst,
                      float fill = 0.0f);

// knn_reg (train/losses.h) with inputs, sets (n, K) and gradients in device memory
// (gradients ADDED atomically). Reads the value back (synchronises).
float knn_reg_cuda(const KnnRegInputs<float>& in, const int32_t* sets, int K, const KnnRegWeights& w = {},
                   const KnnRegGrads<float>* grads = nullptr, float grad_scale = 1.0f);

}  // namespace haha::cuda
