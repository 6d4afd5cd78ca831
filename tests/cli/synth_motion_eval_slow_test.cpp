// A walk scored against the truth through the `haha` executable: synth -> train (shortened
// tiny schedule) -> motion -> synth --motion --part-masks -> eval --data --part garment.
// The run trained on the turn is scored on the walk's frames, with the PSNR over the skirt's
// pixels; scored again with a looser depth test (--depth-margin), the naive merge shows
// Gaussians the run's test hid; with --pose-from every row is scored at the full Gaussians'
// poses. Skips when the executable has not been built next to this test (build/cli/haha).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
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

TEST(SynthMotionEvalSlow, ARunTrainedOnTheTurnIsScoredOnAWalkAndItsSkirt) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-synth-motion-eval-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "log.txt";
  const std::string d = dir.string();
  ASSERT_EQ(run("synth --out '" + d + "/data' --size 64 --frames 8 --test-frames 2 --body-resolution low", log), 0)
      << slurp(log);
  ASSERT_EQ(run("train --data '" + d + "/data' --model '" + d + "/data/body_model.npz' --out '" + d +
                    "/run' --preset tiny resolution=64 s1.steps=40 s2.steps=20 s3.steps=20 s1.densify.from=10 "
                    "s1.densify.until=30 s1.densify.every=10 s3.prune_every=10 s2.texture_size=64 log_every=1000",
                log),
            0)
      << slurp(log);
  ASSERT_EQ(run("motion --kind walk --frames 48 --out '" + d + "/walk.npz'", log), 0) << slurp(log);
  ASSERT_EQ(run("synth --motion '" + d + "/walk.npz' --every 12 --out '" + d +
                    "/walk' --size 64 --body-resolution low --part-masks",
                log),
            0)
      << slurp(log);
  // Without part masks the garment cannot be scored: one line naming the missing file.
  ASSERT_EQ(run("eval --run '" + d + "/run' --data '" + d + "/data' --part garment --tto-steps 0 --out '" + d +
                    "/e0'",
                log),
            1);
  EXPECT_NE(slurp(log).find("haha: error: " + d + "/data/part_masks/000008.png: no part mask"), std::string::npos)
      << slurp(log);  // the first test frame follows the 8 training frames

  ASSERT_EQ(run("eval --run '" + d + "/run' --data '" + d + "/walk' --part garment --tto-steps 0 --out '" + d +
                    "/eval'",
                log),
            0)
      << slurp(log);
  const auto j = nlohmann::json::parse(slurp(dir / "eval" / "report.json"));
  EXPECT_EQ(j["part"], "garment");
  EXPECT_EQ(j["data"], d + "/walk");
  ASSERT_EQ(j["variants"].size(), 4u);
  for (const auto& v : j["variants"]) {
    ASSERT_EQ(v["frames"].size(), 4u);  // 48 frames, every 12th
    ASSERT_TRUE(v["psnr_part"].is_number()) << v["name"];
    // The skirt is the hard part: its pixels score below the whole frame (mostly black
    // background, which every variant gets right).
    EXPECT_LT(v["psnr_part"].get<double>(), v["psnr"].get<double>()) << v["name"];
    EXPECT_GT(v["psnr_part"].get<double>(), 5.0) << v["name"];
  }
  // The same frames with every Gaussian up to 0.5 m behind the mesh shown: the naive merge
  // changes (stage 1's Gaussians sit on and under the surface), the report says why.
  ASSERT_EQ(run("eval --run '" + d + "/run' --data '" + d + "/walk' --variants naive --depth-margin 0.5 --tto-steps 0 --out '" +
                    d + "/loose'",
                log),
            0)
      << slurp(log);
  const auto loose = nlohmann::json::parse(slurp(dir / "loose" / "report.json"));
  ASSERT_EQ(loose["variants"].size(), 1u);
  EXPECT_NE(loose["variants"][0]["psnr"].get<double>(), j["variants"][2]["psnr"].get<double>());
  EXPECT_NE(loose.dump().find("eval depth margin=0.5"), std::string::npos) << loose.dump();
  EXPECT_EQ(run("eval --run '" + d + "/run' --variants naive --depth-margin 2 --out '" + d + "/bad'", log), 1);
  EXPECT_NE(slurp(log).find("--depth-margin"), std::string::npos) << slurp(log);
  // Every row at the poses the full Gaussians found: they are scored first, added when not
  // asked for, and the report says so.
  ASSERT_EQ(run("eval --run '" + d + "/run' --data '" + d + "/walk' --variants naive --pose-from full --tto-steps 3 "
                "--coverage-oracle texel --out '" + d + "/shared'",
                log),
            0)
      << slurp(log);
  const auto shared = nlohmann::json::parse(slurp(dir / "shared" / "report.json"));
  ASSERT_EQ(shared["variants"].size(), 3u);  // texel: the mesh row measures the coverage first
  EXPECT_EQ(shared["variants"][0]["name"], "full Gaussians");
  EXPECT_EQ(shared["variants"][1]["name"], "mesh only");
  EXPECT_EQ(shared["variants"][2]["name"], "naive merge");
  EXPECT_EQ(shared["variants"][2]["frames"][0]["tto_loss_start"].get<double>(), 0.0);  // no fit of its own
  EXPECT_NE(shared.dump().find("eval poses from full"), std::string::npos);
  EXPECT_NE(shared.dump().find("eval mesh coverage oracle texel"), std::string::npos);
  EXPECT_EQ(run("eval --run '" + d + "/run' --coverage-oracle texel --pose-from haha --out '" + d + "/bad'", log), 1);
  EXPECT_NE(slurp(log).find("--coverage-oracle: texel scores the mesh row before the merges"), std::string::npos)
      << slurp(log);
  EXPECT_EQ(run("eval --run '" + d + "/run' --pose-from all --out '" + d + "/bad'", log), 1);
  EXPECT_NE(slurp(log).find("--pose-from: unknown variant 'all'"), std::string::npos) << slurp(log);
  fs::remove_all(dir);
}

}  // namespace
