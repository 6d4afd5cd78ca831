// The training drivers' step loop (train/train_loop.h) on the trainer tests' scene: every
// step reaches the driver once, in order, with the stage ends where the config puts them;
// the driver's stop ends it between steps and a second loop goes on from there; lines
// come only when asked for, an event line after its progress line; an exception from the
// stop hook leaves the loop.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "support/train_test_scene.h"
#include "train/train_loop.h"
#include "train/trainer.h"

namespace haha {
namespace {

using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

const std::vector<TrainFrame>& frames() {
  static const std::vector<TrainFrame> f = scene_frames(scene_truth(), 4, 40);
  return f;
}

TEST(TrainLoop, EveryStepOnceInOrderWithStageEndsAndStopsBetweenSteps) {
  const TrainConfig c = scene_config(5, 3, 4);
  Trainer t(c, scene_input(frames()));
  std::vector<std::pair<int, int>> seen;  // (stage, step)
  std::vector<int> stage_ends;
  std::vector<std::string> lines;
  TrainLoopHooks h;
  h.stop = [](int64_t steps_run) { return steps_run >= 7; };
  h.print_line = [](const StepReport& r, bool stage_end) { return stage_end || !r.event.empty(); };
  h.log = [&](const std::string& line) { lines.push_back(line); };
  h.after_step = [&](const StepReport& r, bool stage_end) {
    seen.emplace_back(r.stage, r.step);
    if (stage_end) stage_ends.push_back(r.stage);
  };
  EXPECT_EQ(run_train_loop(t, h), 7);
  EXPECT_FALSE(t.done());
  EXPECT_EQ(t.stage(), 2);
  EXPECT_EQ(t.step_in_stage(), 2);
  // The rest, without a stop hook.
  h.stop = nullptr;
  EXPECT_EQ(run_train_loop(t, h), 12 - 7);
  EXPECT_TRUE(t.done());
  const std::vector<std::pair<int, int>> expected = {{1, 1}, {1, 2}, {1, 3}, {1, 4}, {1, 5}, {2, 1},
                                                     {2, 2}, {2, 3}, {3, 1}, {3, 2}, {3, 3}, {3, 4}};
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(stage_ends, (std::vector<int>{1, 2, 3}));
  // A line for each stage end (and each event, indented after its step's line).
  int progress = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind("[stage ", 0) == 0) {
      ++progress;
    } else {
      ASSERT_EQ(lines[i].rfind("  ", 0), 0u) << lines[i];
      ASSERT_GT(i, 0u);
      EXPECT_EQ(lines[i - 1].rfind("[stage ", 0), 0u) << "an event line follows its progress line";
    }
  }
  EXPECT_GE(progress, 3);
  EXPECT_EQ(run_train_loop(t, h), 0) << "a finished run has nothing to step";
}

TEST(TrainLoop, NoLinesUnlessAskedAndAThrowingStopLeavesTheLoop) {
  const TrainConfig c = scene_config(3, 1, 1);
  Trainer t(c, scene_input(frames()));
  int logged = 0;
  TrainLoopHooks h;
  h.log = [&](const std::string&) { ++logged; };
  h.stop = [](int64_t steps_run) {
    if (steps_run == 2) throw std::runtime_error("interrupted");
    return false;
  };
  EXPECT_THROW(run_train_loop(t, h), std::runtime_error);
  EXPECT_EQ(t.completed_steps(), 2);
  EXPECT_EQ(logged, 0);
}

}  // namespace
}  // namespace haha
