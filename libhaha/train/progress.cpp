#include "train/progress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "train/levels.h"

namespace haha {

std::string format_duration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  const int t = int(std::lround(s));
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%dh%02dm", t / 3600, (t / 60) % 60);
  else if (t >= 60)
    std::snprintf(buf, sizeof buf, "%dm%02ds", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%ds", t);
  return buf;
}

TrainProgress::TrainProgress(const TrainConfig& c, int done_in_stage)
    : steps_{c.s1.steps, c.s2.steps, c.s3.steps}, stage_start_(std::chrono::steady_clock::now()),
      started_at_(done_in_stage) {
  const std::string* levels[3] = {&c.s1.levels, &c.s2.levels, &c.s3.levels};
  for (int s = 0; s < 3; ++s) {
    const LevelSchedule ls = make_level_schedule(*levels[s], steps_[size_t(s)], "levels");
    const int L = ls.num_levels();
    std::vector<double>& w = work_before_[size_t(s)];
    w.assign(1, 0.0);
    for (int k = 0; k < steps_[size_t(s)]; ++k) {
      const double side = std::ldexp(1.0, ls.level_of(k) - (L - 1));  // 1 at full size
      w.push_back(w.back() + 0.1 + 0.9 * side * side);  // measured: a 128-px step of 512 costs ~1/7
    }
  }
}

double TrainProgress::work(int s, int a, int b) const {
  const std::vector<double>& w = work_before_[size_t(s - 1)];
  const int n = int(w.size()) - 1;
  a = std::clamp(a, 0, n);
  b = std::clamp(b, a, n);
  return w[size_t(b)] - w[size_t(a)];
}

void TrainProgress::update(const StepReport& r, bool stage_end) {
  const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - stage_start_).count();
  rate_ = el > 0 ? (r.step - started_at_) / el : 0.0;
  // This stage at its measured rate of work, later stages at that rate scaled by their
  // typical relative step cost (stage 2 touches only the texture, stage 3 has no LBS or
  // position gradients); a rough guide, refined as each stage starts.
  const double cost[3] = {1.0, 0.15, 0.4};
  const double done = work(r.stage, started_at_, r.step);
  const double work_rate = el > 0 && done > 0 ? done / el : 0.0;
  eta_ = work_rate > 0 ? work(r.stage, r.step, r.steps) / work_rate : NAN;
  for (int s = r.stage + 1; s <= 3 && work_rate > 0; ++s)
    eta_ += work(s, 0, steps_[size_t(s - 1)]) * cost[s - 1] / cost[r.stage - 1] / work_rate;
  if (stage_end) {
    stage_start_ = std::chrono::steady_clock::now();
    started_at_ = 0;
  }
}

std::string progress_line(const StepReport& r, double rate, double eta) {
  char buf[512];
  const LossTerms& l = r.loss;
  std::string parts;
  auto add = [&](const char* name, double v) {
    if (v == 0) return;
    char b[48];
    std::snprintf(b, sizeof b, " %s %.4g", name, v);
    parts += b;
  };
  add("l2", l.l2);
  add("ssim", l.ssim);
  add("sobel", l.sobel);
  add("lpips", l.lpips);
  add("knn", l.knn);
  add("dice", l.dice);
  add("tv", l.tv);
  add("opac", l.opacity);
  add("stretch", l.stretch);
  std::snprintf(buf, sizeof buf, "[stage %d] %d/%d loss %.5f (%s) G %d | %.2f it/s | ETA %s%s", r.stage, r.step,
                r.steps, l.total, parts.empty() ? "" : parts.c_str() + 1, r.gaussians, rate, format_duration(eta).c_str(),
                r.skipped ? " | SKIPPED (non-finite)" : "");
  return buf;
}

}  // namespace haha
