// The views a turn never shows, through the `haha` executable: synth --unseen -> train
// (shortened tiny schedule) -> eval --split unseen. The report scores the unseen frames and
// gives every row the PSNR over the person's pixels; a dataset without the split, and a
// split that does not exist, are one-line errors. Skips when the executable has not been
// built next to this test (build/cli/haha).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "support/haha_cli.h"

namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;

int run(const std::string& args, const fs::path& log) {
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + log.string() + "' 2>&1";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

// The command's output is exactly one error line starting with `start`.
void expect_one_line_error(const fs::path& log, const std::string& start) {
  const std::string msg = slurp(log);
  EXPECT_EQ(msg.rfind(start, 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), msg.size() - 1) << "one line: " << msg;
}

TEST(SynthUnseenEvalSlow, TheUnseenViewsAreScoredWithThePersonsPsnr) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-synth-unseen-eval-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "log.txt";
  const std::string d = dir.string();
  ASSERT_EQ(run("synth --out '" + d + "/data' --size 64 --frames 8 --test-frames 2 --unseen --body-resolution low",
                log),
            0)
      << slurp(log);
  EXPECT_NE(slurp(log).find("8 train + 2 test + 3 unseen frames"), std::string::npos) << slurp(log);
  ASSERT_EQ(run("train --data '" + d + "/data' --model '" + d + "/data/body_model.npz' --out '" + d +
                    "/run' --preset tiny resolution=64 s1.steps=40 s2.steps=20 s3.steps=20 s1.densify.from=10 "
                    "s1.densify.until=30 s1.densify.every=10 s3.prune_every=10 s2.texture_size=64 log_every=1000",
                log),
            0)
      << slurp(log);

  ASSERT_EQ(run("eval --run '" + d + "/run' --split unseen --tto-steps 3 --out '" + d + "/eval'", log), 0)
      << slurp(log);
  const auto j = nlohmann::json::parse(slurp(dir / "eval" / "report.json"));
  EXPECT_EQ(j["split"], "unseen");
  ASSERT_EQ(j["variants"].size(), 4u);
  for (const auto& v : j["variants"]) {
    ASSERT_EQ(v["frames"].size(), 3u) << v["name"];  // below chin, above head, arms raised
    ASSERT_TRUE(v["psnr_person"].is_number()) << v["name"];
    // The person is the hard part: its pixels score below the whole frame (mostly black
    // background, which every variant gets right).
    EXPECT_LT(v["psnr_person"].get<double>(), v["psnr"].get<double>()) << v["name"];
    EXPECT_GT(v["psnr_person"].get<double>(), 5.0) << v["name"];
    for (const auto& f : v["frames"]) EXPECT_TRUE(f["psnr_person"].is_number()) << v["name"];
  }
  EXPECT_NE(slurp(dir / "eval" / "report.md").find("person PSNR"), std::string::npos);
  EXPECT_NE(slurp(log).find("person "), std::string::npos) << slurp(log);  // the table printed while it runs

  // The test split of the same run still scores its 2 frames.
  ASSERT_EQ(run("eval --run '" + d + "/run' --variants mesh --tto-steps 0 --out '" + d + "/test'", log), 0)
      << slurp(log);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir / "test" / "report.json"))["variants"][0]["frames"].size(), 2u);

  // A split that does not exist; a dataset written without the unseen views.
  EXPECT_EQ(run("eval --run '" + d + "/run' --split sideways --out '" + d + "/bad'", log), 1);
  expect_one_line_error(log, "haha: error: --split: split 'sideways' is not");
  ASSERT_EQ(run("synth --out '" + d + "/plain' --size 64 --frames 4 --test-frames 1 --body-resolution low", log), 0)
      << slurp(log);
  EXPECT_EQ(run("eval --run '" + d + "/run' --data '" + d + "/plain' --split unseen --out '" + d + "/bad'", log), 1);
  expect_one_line_error(log, "haha: error: " + d + "/plain: no unseen frames (write the dataset with haha synth --unseen)");
  fs::remove_all(dir);
}

}  // namespace
