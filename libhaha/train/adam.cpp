#include "train/adam.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"

namespace haha {

double LogLinearLr::operator()(int64_t step) const {
  if (step < 0 || (lr_init == 0.0 && lr_final == 0.0)) return 0.0;
  double delay = 1.0;
  if (delay_steps > 0) {
    const double s = std::clamp(double(step) / double(delay_steps), 0.0, 1.0);
    delay = delay_mult + (1.0 - delay_mult) * std::sin(0.5 * M_PI * s);
  }
  const double t = max_steps > 0 ? std::clamp(double(step) / double(max_steps), 0.0, 1.0) : 1.0;
  return delay * std::exp(std::log(lr_init) * (1.0 - t) + std::log(lr_final) * t);
}

int Adam::add_group(const std::string& name, int64_t size, double lr, int stride) {
  if (has_group(name)) fail("adam", "group '" + name + "' registered twice");
  if (stride < 1 || size < 0 || size % stride != 0)
    fail("adam", "group '" + name + "': size " + std::to_string(size) + " is not a multiple of stride " +
                     std::to_string(stride));
  Group g;
  g.name = name;
  g.lr = lr;
  g.stride = stride;
  g.m.assign(size_t(size), 0.0f);
  g.v.assign(size_t(size), 0.0f);
  groups_.push_back(std::move(g));
  return int(groups_.size()) - 1;
}

bool Adam::has_group(const std::string& name) const {
  return std::any_of(groups_.begin(), groups_.end(), [&](const Group& g) { return g.name == name; });
}

int Adam::group(const std::string& name) const {
  for (size_t i = 0; i < groups_.size(); ++i)
    if (groups_[i].name == name) return int(i);
  fail("adam", "no parameter group '" + name + "'");
}

void Adam::step(int gi, float* params, const float* grads) {
  Group& g = groups_.at(size_t(gi));
  ++g.t;
  const AdamStepCoeffs k = adam_step_coeffs(config_, g.lr, g.t);
  float* m = g.m.data();
  float* v = g.v.data();
  parallel_for(int64_t(g.m.size()), [&](int64_t i) { adam_update(params[i], m[i], v[i], grads[i], k); });
}

void Adam::reindex(int gi, const std::vector<int64_t>& source) {
  Group& g = groups_.at(size_t(gi));
  const int64_t old_n = int64_t(g.m.size()) / g.stride;
  const int s = g.stride;
  std::vector<float> m(source.size() * size_t(s), 0.0f), v(source.size() * size_t(s), 0.0f);
  for (size_t e = 0; e < source.size(); ++e) {
    const int64_t from = source[e];
    if (from >= old_n)
      fail("adam", "group '" + g.name + "': reindex source " + std::to_string(from) + " out of range (" +
                       std::to_string(old_n) + " elements)");
    if (from < 0) continue;
    std::copy_n(g.m.begin() + from * s, s, m.begin() + int64_t(e) * s);
    std::copy_n(g.v.begin() + from * s, s, v.begin() + int64_t(e) * s);
  }
  g.m = std::move(m);
  g.v = std::move(v);
}

void Adam::reset_moments(int gi) {
  Group& g = groups_.at(size_t(gi));
  std::fill(g.m.begin(), g.m.end(), 0.0f);
  std::fill(g.v.begin(), g.v.end(), 0.0f);
}

void Adam::set_state(int gi, std::vector<float> m, std::vector<float> v, int64_t t) {
  Group& g = groups_.at(size_t(gi));
  if (m.size() != v.size() || m.size() % size_t(g.stride) != 0 || t < 0)
    fail("adam", "group '" + g.name + "': state of " + std::to_string(m.size()) + " / " + std::to_string(v.size()) +
                     " values does not fit stride " + std::to_string(g.stride));
  g.m = std::move(m);
  g.v = std::move(v);
  g.t = t;
}

std::map<std::string, std::vector<float>> Adam::state() const {
  std::map<std::string, std::vector<float>> s;
  for (const Group& g : groups_) {
    const std::string k = "adam." + g.name + ".";
    s[k + "m"] = g.m;
    s[k + "v"] = g.v;
    s[k + "step"] = {float(g.t)};
    s[k + "stride"] = {float(g.stride)};
  }
  return s;
}

void Adam::load_state(const std::map<std::string, std::vector<float>>& state, const std::string& where) {
  std::vector<Group> loaded = groups_;
  for (Group& g : loaded) {
    const std::string k = "adam." + g.name + ".";
    auto get = [&](const std::string& key) -> const std::vector<float>& {
      auto it = state.find(key);
      if (it == state.end()) fail(where, key + ": missing");
      return it->second;
    };
    const auto& m = get(k + "m");
    const auto& v = get(k + "v");
    const auto& t = get(k + "step");
    const auto& st = get(k + "stride");
    if (st.size() != 1 || st[0] != float(g.stride))
      fail(where, k + "stride: expected " + std::to_string(g.stride));
    if (v.size() != m.size()) fail(where, k + "v: size " + std::to_string(v.size()) + " differs from m's " + std::to_string(m.size()));
    if (m.size() % size_t(g.stride) != 0)
      fail(where, k + "m: size " + std::to_string(m.size()) + " is not a multiple of stride " + std::to_string(g.stride));
    if (t.size() != 1 || !(t[0] >= 0.0f) || t[0] != std::floor(t[0]) || t[0] > 16777216.0f)
      fail(where, k + "step: not a step count");
    g.m = m;
    g.v = v;
    g.t = int64_t(t[0]);
  }
  groups_ = std::move(loaded);  // all or nothing
}

}  // namespace haha
