// Crash safety: SIGKILL at random moments of `haha train`, `pack`, `unpack`, `render`,
// `eval` and `convert` never leaves a half-written output under its final name (every output that exists
// reads back whole), and `train --resume` after repeated kills ends bit-identical to an
// uninterrupted run (the avatar files are compared byte for byte).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "data/dataset.h"
#include "format/avatar_unpack.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/ply_3dgs.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;

// Runs haha with `args`; kills it with SIGKILL after `kill_after_ms` unless it ended.
// Returns the exit code, or -1 when it was killed.
int run_maybe_killed(const std::vector<std::string>& args, int kill_after_ms) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    std::vector<char*> argv{const_cast<char*>(kHaha.c_str())};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    setenv("OMP_WAIT_POLICY", "passive", 1);
    execv(kHaha.c_str(), argv.data());
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kill_after_ms);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<uint8_t> bytes_of(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Every file under `dir` with a final name (not a *.tmp-PID working file) reads back whole,
// and so does every dataset directory (one with a dataset.json).
void expect_outputs_whole(const fs::path& dir, const std::string& when) {
  if (!fs::exists(dir)) return;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const fs::path p = e.path();
    if (e.is_directory() && p.filename().string().find(".tmp-") == std::string::npos &&
        fs::exists(p / "dataset.json")) {
      SCOPED_TRACE(when + ": dataset " + p.string());
      try {
        read_dataset(p.string(), LoadPixels::all);
      } catch (const std::exception& ex) {
        ADD_FAILURE() << "half-written dataset: " << ex.what();
      }
    }
    if (!e.is_regular_file()) continue;
    const std::string name = p.filename().string(), ext = p.extension().string();
    if (name.find(".tmp-") != std::string::npos) continue;  // not yet renamed: not an output
    SCOPED_TRACE(when + ": " + p.string());
    try {
      if (ext == ".npz") {
        Npz::read(p.string());
      } else if (ext == ".json") {
        const nlohmann::json j = nlohmann::json::parse(bytes_of(p));
        (void)j;
      } else if (ext == ".png" || ext == ".jpg" || ext == ".webp") {
        read_image(p.string());
      } else if (ext == ".glb") {
        read_avatar_file(p.string());
      } else if (ext == ".ply") {
        read_ply_3dgs(p.string());
      } else if (ext == ".md" || ext == ".obj" || ext == ".gp") {
        EXPECT_GT(fs::file_size(p), 0u);
      }
    } catch (const std::exception& ex) {
      ADD_FAILURE() << "half-written output: " << ex.what();
    }
  }
}

class CrashSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
    dir_ = fs::temp_directory_path() / ("haha-crash-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ASSERT_EQ(run_maybe_killed({"synth", "--out", (dir_ / "data").string(), "--size", "32", "--frames", "6",
                                "--test-frames", "2", "--body-resolution", "low", "--supersample", "1"},
                               600000),
              0);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<std::string> train_args(const fs::path& run, bool resume) const {
    std::vector<std::string> a = {"train", "--data", (dir_ / "data").string(), "--out", run.string()};
    if (resume) {
      a.push_back("--resume");
      return a;  // the run's saved config
    }
    for (const char* kv : {"--preset", "tiny", "resolution=32", "s1.steps=40", "s2.steps=20", "s3.steps=20",
                           "checkpoint_every=1", "s1.densify.from=10", "s1.densify.every=15", "s1.densify.until=35",
                           "s3.prune_every=10", "s2.texture_size=32", "eval.tto_steps=2"})
      a.push_back(kv);
    return a;
  }
  // An SMPLify-X layout of `n` frames (the fixture pickles, cycled) at 96 x 96.
  fs::path smplifyx_input(int n) const {
    const fs::path fits = dir_ / "fits";
    const fs::path pickles = fs::path(__FILE__).parent_path().parent_path() / "fixtures" / "pickle" / "smplifyx";
    fs::create_directories(fits / "images");
    fs::create_directories(fits / "masks");
    for (int i = 0; i < n; ++i) {
      char stem[16];
      std::snprintf(stem, sizeof stem, "%05d", i);
      Image rgb(96, 96, 3), mask(96, 96, 1);
      for (size_t k = 0; k < rgb.data.size(); ++k) rgb.data[k] = float((k * 7 + size_t(i) * 13) % 256) / 255.0f;
      for (int y = 20; y < 80; ++y)
        for (int x = 30; x < 66; ++x) mask.at(x, y, 0) = 1.0f;
      fs::create_directories(fits / "results" / stem);
      write_image((fits / "images" / (std::string(stem) + ".png")).string(), rgb);
      write_image((fits / "masks" / (std::string(stem) + ".png")).string(), mask);
      char src[16];
      std::snprintf(src, sizeof src, "%05d", i % 3);
      fs::copy_file(pickles / src / "000.pkl", fits / "results" / stem / "000.pkl");
    }
    return fits;
  }
  fs::path dir_;
};

TEST_F(CrashSafety, KilledTrainingResumesToTheSameAvatarAndOtherCommandsLeaveNoHalfFiles) {
  const fs::path ref = dir_ / "ref", run = dir_ / "killed";
  ASSERT_EQ(run_maybe_killed(train_args(ref, false), 600000), 0);

  std::mt19937 rng(7);
  std::uniform_int_distribution<int> delay(50, 2500);
  int kills = 0, code = -1;
  for (int attempt = 0; attempt < 60 && code != 0; ++attempt) {
    // Resume where a checkpoint exists; before the first one, start again.
    const bool resume = fs::exists(run / "checkpoint.npz");
    code = run_maybe_killed(train_args(run, resume), delay(rng));
    kills += code == -1;
    expect_outputs_whole(run, "train, attempt " + std::to_string(attempt));
    ASSERT_TRUE(code == 0 || code == -1) << "train failed with exit code " << code;
  }
  if (code != 0) code = run_maybe_killed(train_args(run, fs::exists(run / "checkpoint.npz")), 600000);
  ASSERT_EQ(code, 0);
  RecordProperty("train_kills", std::to_string(kills));
  EXPECT_GT(kills, 0);
  for (const char* f : {"avatar.npz", "avatar_stage1.npz", "smplx_refined.npz"})
    EXPECT_EQ(bytes_of(ref / f), bytes_of(run / f)) << f << " differs from the uninterrupted run's";
  // The final state too, all but the wall-clock times it records.
  const Npz a = Npz::read((ref / "checkpoint.npz").string()), b = Npz::read((run / "checkpoint.npz").string());
  EXPECT_EQ(a.keys(), b.keys());
  for (const std::string& k : a.keys()) {
    if (k.rfind("f64/time.", 0) == 0) continue;
    EXPECT_EQ(a.get(k).bytes, b.get(k).bytes) << "checkpoint " << k;
  }

  // The other commands, killed at random moments: outputs are whole or absent.
  const std::string glb = (dir_ / "out" / "a.glb").string();
  fs::create_directories(dir_ / "out");
  ASSERT_EQ(run_maybe_killed({"pack", ref.string(), "--out", glb}, 600000), 0);
  ASSERT_EQ(run_maybe_killed({"motion", "--out", (dir_ / "m.npz").string(), "--frames", "6"}, 600000), 0);
  const std::string body = (dir_ / "body.npz").string();
  ASSERT_EQ(run_maybe_killed({"synth-body", "--out", body, "--resolution", "low"}, 600000), 0);
  const fs::path fits = smplifyx_input(24);
  // Uninterrupted, the conversion succeeds (so the killed ones below are cut mid-work).
  ASSERT_EQ(run_maybe_killed({"convert", "--from", "smplifyx", "--in", fits.string(), "--body", body, "--out",
                              (dir_ / "converted_whole").string()},
                             600000),
            0);
  const std::vector<std::vector<std::string>> commands = {
      {"pack", ref.string(), "--out", (dir_ / "out" / "b.glb").string(), "--lossless"},
      {"unpack", glb, "--out", (dir_ / "out" / "unpacked").string()},
      {"render", glb, "--motion", (dir_ / "m.npz").string(), "--out", (dir_ / "out" / "frames").string(), "--size", "48"},
      {"eval", "--run", ref.string(), "--tto-steps", "2"},
      {"convert", "--from", "smplifyx", "--in", fits.string(), "--body", body, "--out",
       (dir_ / "out" / "converted").string()}};
  int other_kills = 0;
  for (const auto& c : commands)
    for (int k = 0; k < 4; ++k) {
      const int code2 = run_maybe_killed(c, delay(rng) / 4);
      other_kills += code2 == -1;
      EXPECT_TRUE(code2 == 0 || code2 == -1) << c[0] << " exit code " << code2;
      expect_outputs_whole(dir_ / "out", c[0]);
      expect_outputs_whole(ref, c[0]);
    }
  RecordProperty("other_kills", std::to_string(other_kills));
  EXPECT_GT(other_kills, 0);
}

}  // namespace
}  // namespace haha
