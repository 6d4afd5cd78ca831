// The step loop of the fits before stage 1 (train/fit_steps.h): its loss windows, its
// progress reports, skipped (NaN) steps left out of both.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "train/fit_steps.h"

namespace haha {
namespace {

TEST(FitSteps, WindowsAndProgress) {
  std::vector<int> ran, done;
  std::vector<double> means;
  const FitLossSpan r = run_fit_steps(
      100, 40,
      [&](int s) {
        ran.push_back(s);
        return s == 41 ? NAN : double(s);
      },
      [&](int d, int total, double loss) {
        EXPECT_EQ(total, 100);
        done.push_back(d);
        means.push_back(loss);
      });
  ASSERT_EQ(ran.size(), 100u);
  EXPECT_EQ(ran.back(), 99);
  EXPECT_DOUBLE_EQ(r.start, (40 + 42) / 2.0);  // [40, 43): step 41 was skipped
  EXPECT_DOUBLE_EQ(r.end, (97 + 98 + 99) / 3.0);
  ASSERT_EQ(done.size(), 20u);  // every 5 steps
  EXPECT_EQ(done.front(), 5);
  EXPECT_EQ(done.back(), 100);
  EXPECT_DOUBLE_EQ(means.front(), 2.0);  // steps 0..4
  EXPECT_DOUBLE_EQ(means[8], (40 + 42 + 43 + 44) / 4.0);  // steps 40..44 without 41
  // No steps: nothing runs, no loss.
  const FitLossSpan none = run_fit_steps(0, 0, [](int) { return 1.0; }, {});
  EXPECT_TRUE(std::isnan(none.start));
  EXPECT_TRUE(std::isnan(none.end));
}

}  // namespace
}  // namespace haha
