// Where the learned filtering stops (s3.validation_every > 0). Stage 3 pushes every Gaussian
// towards deletion with one fixed opacity weight, so it keeps whatever that weight leaves,
// whether or not the ones it deleted were still needed. With validation views (training
// frames that no stage trains on), the avatar is scored at the start of stage 3 and after
// every prune: the points (step, Gaussians, PSNR) of one filtering run, the count falling.
// The stage ends on the point with the fewest Gaussians whose PSNR is within stop_db of the
// best point's, among those that keep at most max_count Gaussians; when none of those is
// within, the best of them; when there are none, the last point (the fixed weight's result).
// Training views cannot judge this: the Gaussians were fitted to them, so every deletion
// costs there (a 0.1 dB budget on them kept 99%), while on frames they never saw the
// filtered avatar often scores above the full one.
//
// Counts only fall along a run, so the choice is kept streaming: the latest eligible point
// within the budget of the best so far (a later best is itself the latest), and the best
// eligible point; their Gaussians are kept, nothing else. The state is part of a checkpoint.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "train/gaussian_params.h"

namespace haha {

struct FilterStopPoint {
  int step = 0;       // stage-3 steps done when it was scored
  int gaussians = 0;
  double psnr = 0;    // mean over the validation views, dB
};

class FilterStop {
 public:
  // Stage 3 begins (or resumes without state): stop_db >= 0, max_count >= 0.
  void begin(double stop_db, int max_count);
  // A scored point; `g` is the state it scored (kept when it may be the choice).
  void observe(int step, double psnr, const GaussianParams& g);

  const std::vector<FilterStopPoint>& points() const { return points_; }
  // Index into points() of the choice, -1 before any point.
  int chosen() const;
  // Gaussians of the choice; null when it is the last point (the trainer's state).
  const GaussianParams* chosen_gaussians() const;

  // Checkpoint state: scalars and points under "filter_stop.*" (f64), and the kept
  // Gaussians, which the trainer writes with its own layout (kept()).
  void save(std::map<std::string, std::vector<double>>& f64) const;
  // Restores save()'s state (the kept Gaussians through kept()); throws haha::Error
  // "<where>: filter_stop: ..." when it is inconsistent.
  void load(const std::map<std::string, std::vector<double>>& f64, const std::string& where);
  // The two kept states by name ("within", "best"), for the checkpoint.
  GaussianParams& kept(const std::string& which) { return which == "within" ? within_g_ : best_g_; }
  const GaussianParams& kept(const std::string& which) const { return which == "within" ? within_g_ : best_g_; }
  bool has_kept(const std::string& which) const { return (which == "within" ? within_ : best_) >= 0; }

 private:
  bool eligible(const FilterStopPoint& p) const { return p.gaussians <= max_count_; }
  double stop_db_ = 0;
  int max_count_ = 0;
  double best_psnr_ = 0;  // over all points
  std::vector<FilterStopPoint> points_;
  int within_ = -1, best_ = -1;  // latest eligible point within budget / best eligible point
  GaussianParams within_g_, best_g_;
};

}  // namespace haha
