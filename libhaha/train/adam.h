// Adam with named parameter groups (one learning rate each), the 3DGS log-linear
// learning-rate decay, moment bookkeeping for densification / pruning, and a flat state
// map for checkpoints.
//
// The optimiser owns only the moments; parameters and gradients stay in the caller's SoA
// float buffers and are passed to step(). The update is torch.optim.Adam's (no weight
// decay, no amsgrad), with the bias corrections of the group's own step count t:
//   m = b1 m + (1 - b1) g;   v = b2 v + (1 - b2) g^2
//   p -= lr / (1 - b1^t) * m / (sqrt(v) / sqrt(1 - b2^t) + eps)
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/hd.h"

namespace haha {

struct AdamConfig {
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-15;  // 3DGS's value (torch's default is 1e-8)
};

// The float constants of one update with learning rate lr at step count t (>= 1), and the
// per-element update: the body of Adam::step, shared with the CUDA launcher.
struct AdamStepCoeffs {
  float step_size, inv_sqrt_bc2, b1, b2, c1, c2, eps;
};
inline AdamStepCoeffs adam_step_coeffs(const AdamConfig& config, double lr, int64_t t) {
  const double b1 = config.beta1, b2 = config.beta2;
  AdamStepCoeffs k;
  k.step_size = float(lr / (1.0 - std::pow(b1, double(t))));
  k.inv_sqrt_bc2 = float(1.0 / std::sqrt(1.0 - std::pow(b2, double(t))));
  // (1 - beta) in double, as torch does in Python: 1 - 0.999f is off by 1e-5 relative.
  k.b1 = float(b1);
  k.b2 = float(b2);
  k.c1 = float(1.0 - b1);
  k.c2 = float(1.0 - b2);
  k.eps = float(config.eps);
  return k;
}
HAHA_HD void adam_update(float& param, float& m, float& v, float grad, const AdamStepCoeffs& k) {
  m = k.b1 * m + k.c1 * grad;
  v = k.b2 * v + k.c2 * grad * grad;
  param -= k.step_size * m / (std::sqrt(v) * k.inv_sqrt_bc2 + k.eps);
}

// 3DGS's position schedule (get_expon_lr_func): log-linear from lr_init at step 0 to
// lr_final at step max_steps, constant lr_final after it; optional warm-up scales it by
// delay_mult + (1 - delay_mult) sin(pi/2 clamp(step / delay_steps, 0, 1)).
// HAHA stage 1: lr_init 1.6e-4, lr_final 1.6e-6 over the stage's steps.
struct LogLinearLr {
  double lr_init = 1.6e-4;
  double lr_final = 1.6e-6;
  int64_t max_steps = 3000;
  int64_t delay_steps = 0;
  double delay_mult = 1.0;
  double operator()(int64_t step) const;  // step < 0 -> 0; lr_init = lr_final = 0 -> 0
};

class Adam {
 public:
  explicit Adam(AdamConfig config = {}) : config_(config) {}

  // Registers `size` scalars (elements of `stride` scalars each, e.g. 3 for positions, 4
  // for quaternions: reindex() moves whole elements). Returns the group's index. Throws
  // haha::Error for a duplicate name, size not a multiple of stride, or stride < 1.
  int add_group(const std::string& name, int64_t size, double lr, int stride = 1);
  bool has_group(const std::string& name) const;
  int group(const std::string& name) const;  // throws haha::Error if unknown
  int num_groups() const { return int(groups_.size()); }
  const std::string& name(int g) const { return groups_.at(size_t(g)).name; }
  int64_t size(int g) const { return int64_t(groups_.at(size_t(g)).m.size()); }
  int stride(int g) const { return groups_.at(size_t(g)).stride; }
  int64_t steps(int g) const { return groups_.at(size_t(g)).t; }
  double lr(int g) const { return groups_.at(size_t(g)).lr; }
  void set_lr(int g, double lr) { groups_.at(size_t(g)).lr = lr; }
  const AdamConfig& config() const { return config_; }
  const std::vector<float>& first_moment(int g) const { return groups_.at(size_t(g)).m; }
  const std::vector<float>& second_moment(int g) const { return groups_.at(size_t(g)).v; }

  // One update of group g; params and grads hold size(g) values. Groups the trainer does
  // not step (frozen in a stage) keep their moments and step count.
  void step(int g, float* params, const float* grads);

  // After densification / pruning: the group becomes source.size() elements; new element
  // e takes old element source[e]'s moments, or zero moments when source[e] < 0 (3DGS
  // gives new Gaussians fresh moments). Prune = the kept indices in order; clone = the
  // old indices followed by the parents (or -1). The step count is kept. Throws
  // haha::Error naming the group for an index >= the old element count.
  void reindex(int g, const std::vector<int64_t>& source);
  void reset_moments(int g);  // zero m and v, keep the size and step count
  // Replaces group g's moments (equal sizes, a multiple of its stride) and step count: a
  // device optimiser hands its state back this way (train/trainer_cuda.cpp).
  void set_state(int g, std::vector<float> m, std::vector<float> v, int64_t t);

  // Checkpoint state: for every group "adam.<name>.m", "adam.<name>.v" (size values),
  // "adam.<name>.step" ({t}, exact up to 2^24 steps) and "adam.<name>.stride" ({stride}).
  // Learning rates are not stored: they come from the run's configuration and schedule.
  std::map<std::string, std::vector<float>> state() const;
  // Restores every registered group from such a map (its size follows the stored arrays;
  // keys of unknown groups are ignored). Throws haha::Error "where: key: problem" for a
  // missing key, a stride or size mismatch, or a bad step count.
  void load_state(const std::map<std::string, std::vector<float>>& state, const std::string& where);

 private:
  struct Group {
    std::string name;
    double lr = 0;
    int stride = 1;
    int64_t t = 0;
    std::vector<float> m, v;
  };
  AdamConfig config_;
  std::vector<Group> groups_;
};

}  // namespace haha
