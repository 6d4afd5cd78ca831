// train_bench through the executable, on the CPU at a tiny scale (what any machine, the
// GPU one included, can run in seconds): the JSON holds the requested step counts and
// finite PSNR / SSIM values; the default size; a bad option is one error line and exit
// code 1; and, where the I/O build made the haha command, its numbers are `haha synth` +
// `haha train` + `haha eval`'s exactly.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "support/haha_cli.h"

namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;

const fs::path kTrainBench = HAHA_TRAIN_BENCH;

class TrainBench : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("haha_train_bench_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs `program args` in the test's directory; stdout and stderr in out_ / err_.
  int run(const fs::path& program, const std::string& args) {
    const std::string cmd = "cd '" + dir_.string() + "' && OMP_WAIT_POLICY=passive '" + program.string() + "' " +
                            args + " > out.txt 2> err.txt";
    const int status = std::system(cmd.c_str());
    out_ = slurp(dir_ / "out.txt");
    err_ = slurp(dir_ / "err.txt");
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  fs::path dir_;
  std::string out_, err_;
};

// Every number that follows "key": in the text from `from` on, in order (null: NaN).
std::vector<double> json_numbers(const std::string& text, const std::string& key, size_t from = 0) {
  std::vector<double> out;
  const std::string needle = "\"" + key + "\": ";
  for (size_t p = text.find(needle, from); p != std::string::npos; p = text.find(needle, p + 1)) {
    const char* s = text.c_str() + p + needle.size();
    char* end = nullptr;
    const double v = std::strtod(s, &end);
    out.push_back(end == s ? NAN : v);
  }
  return out;
}

// The first "key" of the object named `name` (its "name" comes first in both files).
double variant_number(const std::string& text, const std::string& name, const std::string& key) {
  const size_t at = text.find("\"name\": \"" + name + "\"");
  if (at == std::string::npos) return NAN;
  const std::vector<double> v = json_numbers(text, key, at);
  return v.empty() ? NAN : v[0];
}

const char* kTiny = "--size 48 --frames 2 --test-frames 2 --set s1.steps=2 --set s2.steps=3 --set s3.steps=4 "
                    "--set resolution=48 --device cpu --threads 2";

TEST_F(TrainBench, TinyCpuRunWritesTheTableAndJson) {
  ASSERT_EQ(run(kTrainBench, std::string(kTiny) + " --json bench.json"), 0) << err_;
  EXPECT_EQ(err_, "");
  for (const char* s : {"1 Gaussians", "2 texture", "3 filtering", "total", "subject generation", "HAHA filtered"})
    EXPECT_NE(out_.find(s), std::string::npos) << s << "\n" << out_;
  const std::string j = slurp(dir_ / "bench.json");
  EXPECT_EQ(json_numbers(j, "steps"), (std::vector<double>{2, 3, 4}));
  const std::vector<double> psnr = json_numbers(j, "psnr"), ssim = json_numbers(j, "ssim");
  ASSERT_EQ(psnr.size(), 3u) << j;  // mesh only, full Gaussians, HAHA filtered
  ASSERT_EQ(ssim.size(), 3u) << j;
  for (double v : psnr) EXPECT_TRUE(std::isfinite(v) && v > 5) << j;
  for (double v : ssim) EXPECT_TRUE(v > 0 && v <= 1) << j;
  for (double v : json_numbers(j, "seconds")) EXPECT_TRUE(std::isfinite(v) && v >= 0) << j;
  for (const auto& e : fs::directory_iterator(dir_))  // written through a temporary name
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// Without --size the frames are rendered at the paper's 544 px (then resampled to the
// config's resolution); --no-eval leaves the evaluation out of the JSON.
TEST_F(TrainBench, DefaultSizeIs544AndNoEvalSkipsTheEvaluation) {
  ASSERT_EQ(run(kTrainBench, "--frames 1 --test-frames 0 --no-eval --set s1.steps=1 --set s2.steps=0 --set s3.steps=0 "
                             "--set resolution=32 --threads 2 --json bench.json"),
            0)
      << err_;
  EXPECT_NE(out_.find("rendered at 544 px"), std::string::npos) << out_;
  EXPECT_EQ(out_.find("evaluation"), std::string::npos) << out_;
  const std::string j = slurp(dir_ / "bench.json");
  EXPECT_EQ(json_numbers(j, "size"), (std::vector<double>{544}));
  EXPECT_EQ(json_numbers(j, "steps"), (std::vector<double>{1, 0, 0}));
  EXPECT_NE(j.find("\"eval\": null"), std::string::npos) << j;
}

TEST_F(TrainBench, BadOptionIsOneErrorLine) {
  const std::pair<const char*, const char*> cases[] = {
      {"--frames abc", "train_bench: error: --frames: 'abc' is not a valid number\n"},
      {"--bogus", "train_bench: error: --bogus: unknown option (see --help)\n"},
      {"--size", "train_bench: error: --size: needs a value\n"},
      {"--device gpu", "train_bench: error: --device: unknown device 'gpu' (expected cpu, cuda or auto)\n"},
      {"--subject 3", "train_bench: error: --subject: 3 is not a subject (expected 1 or 2)\n"},
      {"--fit-noise-pose 2", "train_bench: error: --fit-noise-pose: must be in [0, 1]\n"},
  };
  for (const auto& [args, line] : cases) {
    EXPECT_EQ(run(kTrainBench, "--json bad.json " + std::string(args)), 1) << args;
    EXPECT_EQ(err_, line) << args;
    EXPECT_EQ(out_, "") << args;  // no work started
  }
  EXPECT_EQ(run(kTrainBench, "--set s1.stepz=3"), 1);
  EXPECT_EQ(err_.rfind("train_bench: error: --set: s1.stepz: ", 0), 0u) << err_;
  EXPECT_EQ(err_.find('\n'), err_.size() - 1) << err_;
  EXPECT_FALSE(fs::exists(dir_ / "bad.json"));
  EXPECT_EQ(run(kTrainBench, "--help"), 0);
  for (const char* opt : {"--subject", "--size", "--frames", "--test-frames", "--fit-noise", "--fit-noise-pose",
                          "--fit-noise-transl", "--preset", "--set",
                          "--device", "--threads", "--no-eval", "--json"})
    EXPECT_NE(out_.find(opt), std::string::npos) << opt;
}

// The same subject, training and evaluation as the dataset route: bit-identical metrics
// (with pose and transl noise of different sizes, so a swap of the two shows).
TEST_F(TrainBench, SameNumbersAsHahaSynthTrainEval) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha << " (HAHA_WITH_IO=OFF)";
  // fits=exact: the noisy dataset would bring the settings for estimated fits, which the
  // benchmark (the preset's schedule) does not take.
  const std::string steps = "s1.steps=2 s2.steps=3 s3.steps=4 resolution=48 fits=exact";
  ASSERT_EQ(run(kHaha, "synth --out ds --size 48 --frames 2 --test-frames 2 --fit-noise-pose 0.03 --fit-noise-transl 0.01"),
            0)
      << err_;
  ASSERT_EQ(run(kHaha, "--threads 2 train --data ds --out run --preset tiny " + steps), 0) << err_;
  ASSERT_EQ(run(kHaha, "--threads 2 eval --run run --data ds --tto-steps 0"), 0) << err_;
  const std::string report = slurp(dir_ / "run" / "report.json");
  ASSERT_EQ(run(kTrainBench, std::string(kTiny) + " --fit-noise-pose 0.03 --fit-noise-transl 0.01 --json bench.json"), 0)
      << err_;
  const std::string bench = slurp(dir_ / "bench.json");
  for (const char* variant : {"mesh only", "full Gaussians", "HAHA filtered"})
    for (const char* key : {"psnr", "ssim"}) {
      const double r = variant_number(report, variant, key), b = variant_number(bench, variant, key);
      EXPECT_TRUE(std::isfinite(r)) << variant << " " << key << "\n" << report;
      EXPECT_EQ(b, r) << variant << " " << key;
    }
}

}  // namespace
