#include "train/filter_budget.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {

void FilterBudget::begin(int num_frames, double budget_db) {
  budget_ = budget_db;
  excess_ = 0;
  scale_ = 1;
  have_excess_ = false;
  best_.assign(budget_db > 0 ? size_t(std::max(0, num_frames)) : 0, std::numeric_limits<double>::infinity());
}

void FilterBudget::observe(const std::vector<int>& frames, double l2) {
  if (budget_ <= 0 || frames.empty() || !(l2 > 0) || !std::isfinite(l2)) return;
  double ref = 0;
  bool seen = true;
  for (int f : frames) {
    if (f < 0 || size_t(f) >= best_.size()) return;
    seen = seen && std::isfinite(best_[size_t(f)]);
    ref += best_[size_t(f)];
  }
  for (int f : frames) best_[size_t(f)] = std::min(best_[size_t(f)], l2);
  if (!seen) return;  // a first visit only sets the frame's best
  ref /= double(frames.size());
  const double e = 10 * std::log10(l2 / ref);
  excess_ = have_excess_ ? (1 - kRate) * excess_ + kRate * e : e;
  have_excess_ = true;
  scale_ = std::clamp(scale_ * std::exp(-kGain * (excess_ - budget_) / budget_), kMinScale, 1.0);
}

void FilterBudget::save(std::map<std::string, std::vector<double>>& f64) const {
  if (budget_ <= 0) return;
  f64["filter_budget.state"] = {budget_, excess_, scale_, have_excess_ ? 1.0 : 0.0};
  f64["filter_budget.best"] = best_;
}

void FilterBudget::load(const std::map<std::string, std::vector<double>>& f64, const std::string& where) {
  const auto st = f64.find("filter_budget.state");
  const auto bt = f64.find("filter_budget.best");
  if (budget_ <= 0) return;  // off in this config: nothing to restore
  if (st == f64.end() || bt == f64.end()) return;  // saved before stage 3: begin() set it up
  if (st->second.size() != 4 || bt->second.size() != best_.size())
    fail(where, "filter_budget: state does not match the run (" + std::to_string(bt->second.size()) + " frames)");
  excess_ = st->second[1];
  scale_ = st->second[2];
  have_excess_ = st->second[3] != 0;
  best_ = bt->second;
}

}  // namespace haha
