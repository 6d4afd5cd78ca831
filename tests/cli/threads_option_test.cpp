// `--threads N` through the executable: accepted after the subcommand as well as before it
// (the README tells newcomers `haha train --threads 1 ...`), listed by every subcommand's
// --help, and it reaches the parallel loops (train_summary.json records the thread count).
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

// Runs `haha ARGS`, stdout and stderr into *out; returns the exit code.
int haha_cli(const std::string& args, const fs::path& dir, std::string* out) {
  const fs::path o = dir / "out.txt";
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + o.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  *out = slurp(o);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class ThreadsOption : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
    dir_ = fs::temp_directory_path() / ("haha-threads-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(ThreadsOption, EverySubcommandHelpListsIt) {
  for (const char* sub : {"train", "eval", "pack", "render", "synth", "fit-video", "bench", "batch run", "batch status"}) {
    std::string out;
    EXPECT_EQ(haha_cli(std::string(sub) + " --help", dir_, &out), 0) << sub;
    EXPECT_NE(out.find("--threads"), std::string::npos) << sub << ":\n" << out;
  }
}

TEST_F(ThreadsOption, AfterTheSubcommandReachesTraining) {
  std::string out;
  ASSERT_EQ(haha_cli("synth --size 32 --frames 2 --test-frames 0 --body-resolution low --out '" + (dir_ / "data").string() + "'",
                     dir_, &out),
            0)
      << out;
  const std::string steps = " s1.steps=2 s2.steps=1 s3.steps=1 s1.densify.every=0";
  for (const int threads : {1, 2}) {
    for (const bool after : {true, false}) {
      const fs::path run = dir_ / ("run" + std::to_string(threads) + (after ? "a" : "b"));
      const std::string t = "--threads " + std::to_string(threads);
      const std::string args = after ? "train " + t : t + " train";
      ASSERT_EQ(haha_cli(args + " --data '" + (dir_ / "data").string() + "' --out '" + run.string() + "' --preset tiny" + steps,
                         dir_, &out),
                0)
          << args << ":\n" << out;
      const auto summary = nlohmann::json::parse(slurp(run / "train_summary.json"));
      EXPECT_EQ(summary.at("threads").get<int>(), threads) << args;
    }
  }
}

TEST_F(ThreadsOption, BadValueNamesTheOption) {
  std::string out;
  EXPECT_NE(haha_cli("pack --threads many x --out y.glb", dir_, &out), 0);
  EXPECT_NE(out.find("--threads"), std::string::npos) << out;
}

}  // namespace
