#include "train/filter_stop.h"

#include <cmath>

#include "core/error.h"

namespace haha {

void FilterStop::begin(double stop_db, int max_count) {
  *this = FilterStop();
  stop_db_ = stop_db;
  max_count_ = max_count;
}

void FilterStop::observe(int step, double psnr, const GaussianParams& g) {
  const FilterStopPoint p{step, g.size(), psnr};
  const int i = int(points_.size());
  points_.push_back(p);
  if (i == 0 || psnr > best_psnr_) best_psnr_ = psnr;
  if (!eligible(p)) return;
  if (psnr >= best_psnr_ - stop_db_) {
    within_ = i;
    within_g_ = g;
  }
  if (best_ < 0 || psnr > points_[size_t(best_)].psnr) {
    best_ = i;
    best_g_ = g;
  }
}

int FilterStop::chosen() const {
  if (within_ >= 0) return within_;
  if (best_ >= 0) return best_;
  return int(points_.size()) - 1;
}

const GaussianParams* FilterStop::chosen_gaussians() const {
  const int c = chosen();
  if (c < 0 || c == int(points_.size()) - 1) return nullptr;
  return c == within_ ? &within_g_ : &best_g_;
}

void FilterStop::save(std::map<std::string, std::vector<double>>& f64) const {
  f64["filter_stop.state"] = {stop_db_, double(max_count_), best_psnr_, double(within_), double(best_)};
  std::vector<double> pts;
  for (const FilterStopPoint& p : points_) pts.insert(pts.end(), {double(p.step), double(p.gaussians), p.psnr});
  f64["filter_stop.points"] = pts;
}

void FilterStop::load(const std::map<std::string, std::vector<double>>& f64, const std::string& where) {
  const auto s = f64.find("filter_stop.state"), q = f64.find("filter_stop.points");
  if (s == f64.end() || q == f64.end()) fail(where, "filter_stop: missing (the run validates its filtering)");
  const std::vector<double>& v = s->second;
  if (v.size() != 5 || q->second.size() % 3 != 0) fail(where, "filter_stop: wrong sizes");
  for (double x : v)
    if (!std::isfinite(x)) fail(where, "filter_stop: not finite");
  FilterStop r;
  r.stop_db_ = v[0];
  r.max_count_ = int(v[1]);
  r.best_psnr_ = v[2];
  r.within_ = int(v[3]);
  r.best_ = int(v[4]);
  const std::vector<double>& p = q->second;
  for (size_t k = 0; k < p.size(); k += 3) r.points_.push_back({int(p[k]), int(p[k + 1]), p[k + 2]});
  const int n = int(r.points_.size());
  if (r.within_ < -1 || r.within_ >= n || r.best_ < -1 || r.best_ >= n) fail(where, "filter_stop: index out of range");
  *this = std::move(r);  // the kept Gaussians follow through kept()
}

}  // namespace haha
