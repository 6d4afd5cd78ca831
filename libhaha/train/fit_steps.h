// The step loop of the fits that run before stage 1 (the photometric pose fit, the clothed
// surface): one place for their progress reports and their before / after losses.
#pragma once

#include <cmath>
#include <functional>

namespace haha {

struct FitLossSpan {
  double start = NAN, end = NAN;  // mean finite loss over the first / last window
};

// Runs step(s) for s = 0 .. steps - 1 (a step returns its loss, NaN when it was skipped);
// calls progress (optional) every 5% of the steps and at the end with the steps done, their
// count and the mean loss since the last call. The windows are 5% of the steps from `first`
// on: [first, first + w) and the last w steps.
FitLossSpan run_fit_steps(int steps, int first, const std::function<double(int)>& step,
                          const std::function<void(int done, int total, double loss)>& progress);

}  // namespace haha
