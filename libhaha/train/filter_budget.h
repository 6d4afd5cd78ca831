// A filtering that knows what it costs (s3.budget_db > 0): stage 3's opacity regulariser
// pushes every Gaussian towards deletion with one fixed weight, so where the textured mesh is
// weak it throws quality away and where it is strong it may keep too much. With a budget, the
// weight is scaled by m in (0, 1] so that the merged render's L2 on the training views stays
// within budget_db dB of the best each view reached in this stage (its first visits hold
// every Gaussian at stage 1's opacity: the full avatar over the mesh).
//
// Per step: excess = 10 log10(L2 / mean of the batch frames' best L2) (a frame's first visit
// only sets its best), smoothed by an exponential average (rate kRate); then
// m <- clamp(m exp(-kGain (excess - budget) / budget), kMinScale, 1): above the budget the
// push fades within a few tens of steps, below it returns. Pruning (opacity below
// s3.prune_threshold) is unchanged; it deletes what the push has already pushed out. The
// state is part of a checkpoint, so a resumed run repeats the uninterrupted one.
// Measured: docs/results.md, "The clothed surface".
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

namespace haha {

class FilterBudget {
 public:
  static constexpr double kRate = 0.05, kGain = 0.05, kMinScale = 1e-3;

  // Stage 3 begins: `budget_db` <= 0 turns it off (the scale stays 1).
  void begin(int num_frames, double budget_db);
  // After a stage-3 step whose batch drew `frames` and whose mean L2 term was `l2`.
  void observe(const std::vector<int>& frames, double l2);
  double scale() const { return scale_; }   // of the opacity weight, for the next step
  double excess_db() const { return excess_; }

  // Checkpoint state under "filter_budget.*" (absent when off).
  void save(std::map<std::string, std::vector<double>>& f64) const;
  // Restores save()'s state; throws haha::Error "<where>: filter_budget: ..." when it does
  // not fit num_frames.
  void load(const std::map<std::string, std::vector<double>>& f64, const std::string& where);

 private:
  double budget_ = 0, excess_ = 0, scale_ = 1;
  bool have_excess_ = false;
  std::vector<double> best_;  // per frame; +inf until seen
};

}  // namespace haha
