#include "train/fit_steps.h"

#include <algorithm>

namespace haha {

FitLossSpan run_fit_steps(int steps, int first, const std::function<double(int)>& step,
                          const std::function<void(int, int, double)>& progress) {
  const int edge = std::max(1, (steps - first) / 20);
  const int every = std::max(1, steps / 20);
  double start = 0, end = 0, since = 0;
  int n_start = 0, n_end = 0, n_since = 0;
  for (int s = 0; s < steps; ++s) {
    const double loss = step(s);
    if (std::isfinite(loss)) {
      if (s >= first && s < first + edge) start += loss, ++n_start;
      if (s >= steps - edge) end += loss, ++n_end;
      since += loss, ++n_since;
    }
    if (progress && ((s + 1) % every == 0 || s + 1 == steps)) {
      progress(s + 1, steps, n_since ? since / n_since : NAN);
      since = 0, n_since = 0;
    }
  }
  FitLossSpan r;
  if (n_start) r.start = start / n_start;
  if (n_end) r.end = end / n_end;
  return r;
}

}  // namespace haha
