// `haha batch run` / `status` end to end without a scheduler (the Slurm array is
// tests/cli/batch_slurm_test.sh): a tiny synthetic subject done, done again without work, a
// SIGTERM mid-training (as scancel or a pod deletion sends) ending retryable with a
// checkpoint, the next run resuming to a byte-identical avatar.glb, and the status table.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

// Starts haha with `args`, stdout and stderr to `log`; returns its pid.
pid_t start(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    std::vector<char*> argv{const_cast<char*>(kHaha.c_str())};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    setenv("OMP_WAIT_POLICY", "passive", 1);
    unsetenv("SLURM_ARRAY_TASK_ID");
    unsetenv("JOB_COMPLETION_INDEX");
    execv(kHaha.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}
int finish(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
int run(const std::vector<std::string>& args, const fs::path& log) { return finish(start(args, log)); }

std::string bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

class BatchCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
    dir_ = fs::temp_directory_path() / ("haha-batch-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ASSERT_EQ(run({"synth", "--out", (dir_ / "d1").string(), "--size", "48", "--frames", "8", "--test-frames", "2",
                   "--body-resolution", "low", "--supersample", "1", "--seed", "1"},
                  dir_ / "synth.log"),
              0);
    std::ofstream(dir_ / "m.txt")
        << "* preset=tiny resolution=48 s0.steps=0 s1.steps=60 s2.steps=10 s3.steps=10 checkpoint_every=1 "
           "s1.densify.from=10 s1.densify.every=15 s1.densify.until=45 s3.prune_every=5 s2.texture_size=32 "
           "eval:tto-steps=0\n"
           "a d1\n"
           "broken missing/folder\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<std::string> batch(const std::string& root, int index) const {
    return {"--threads", "1", "batch", "run", (dir_ / "m.txt").string(), "--out", (dir_ / root).string(),
            "--index", std::to_string(index)};
  }
  fs::path dir_;
};

TEST_F(BatchCli, DoneSkippedInterruptedResumedToTheSameBytes) {
  // Uninterrupted, then again: no work.
  ASSERT_EQ(run(batch("ref", 0), dir_ / "ref.log"), 0) << slurp(dir_ / "ref.log");
  const fs::path glb = dir_ / "ref" / "a" / "avatar.glb";
  ASSERT_TRUE(fs::exists(glb));
  const auto mtime = fs::last_write_time(glb);
  const std::string done = slurp(dir_ / "ref" / "a" / "done.json");
  ASSERT_EQ(run(batch("ref", 0), dir_ / "again.log"), 0);
  EXPECT_NE(slurp(dir_ / "again.log").find("already done"), std::string::npos) << slurp(dir_ / "again.log");
  EXPECT_EQ(fs::last_write_time(glb), mtime);
  EXPECT_EQ(slurp(dir_ / "ref" / "a" / "done.json"), done);
  // Bad input: 65, and 65 again without a second attempt.
  EXPECT_EQ(run(batch("ref", 1), dir_ / "bad.log"), 65);
  EXPECT_EQ(run(batch("ref", 1), dir_ / "bad2.log"), 65);
  EXPECT_NE(slurp(dir_ / "bad2.log").find("not retried"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "ref" / "broken" / "failed.json"))["attempts"], 1);
  // Usage: index out of range.
  EXPECT_EQ(run(batch("ref", 2), dir_ / "usage.log"), 64);

  // SIGTERM after the first checkpoint: retryable (75), a checkpoint, failed.json.
  const fs::path ck = dir_ / "cut" / "a" / "run" / "checkpoint.npz";
  const pid_t pid = start(batch("cut", 0), dir_ / "cut.log");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (!fs::exists(ck) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  kill(pid, SIGTERM);
  ASSERT_EQ(finish(pid), 75) << slurp(dir_ / "cut.log");
  const nlohmann::json f = nlohmann::json::parse(slurp(dir_ / "cut" / "a" / "failed.json"));
  EXPECT_EQ(f["kind"], "retryable");
  EXPECT_EQ(f["stage"], "train");
  EXPECT_FALSE(fs::exists(dir_ / "cut" / "a" / "running.json"));
  EXPECT_NE(slurp(dir_ / "cut" / "a" / "log.txt").find("checkpoint written"), std::string::npos);
  ASSERT_EQ(run({"batch", "status", (dir_ / "m.txt").string(), "--out", (dir_ / "cut").string()}, dir_ / "st.log"), 0);
  EXPECT_NE(slurp(dir_ / "st.log").find("failed    retryable   train: interrupted"), std::string::npos)
      << slurp(dir_ / "st.log");
  // Resumed: the same bytes as the uninterrupted run.
  ASSERT_EQ(run(batch("cut", 0), dir_ / "resume.log"), 0) << slurp(dir_ / "resume.log");
  EXPECT_NE(slurp(dir_ / "resume.log").find("resumed "), std::string::npos);
  const nlohmann::json d = nlohmann::json::parse(slurp(dir_ / "cut" / "a" / "done.json"));
  EXPECT_EQ(d["attempts"], 2);
  EXPECT_EQ(d["resumed"], true);
  EXPECT_FALSE(fs::exists(dir_ / "cut" / "a" / "failed.json"));
  EXPECT_EQ(bytes(dir_ / "cut" / "a" / "avatar.glb"), bytes(glb)) << "the resumed avatar differs";

  ASSERT_EQ(run({"batch", "status", (dir_ / "m.txt").string(), "--out", (dir_ / "cut").string(), "--json"},
                dir_ / "st.json"),
            0);
  const nlohmann::json st = nlohmann::json::parse(slurp(dir_ / "st.json"));
  EXPECT_EQ(st["counts"]["done"], 1);
  EXPECT_EQ(st["counts"]["pending"], 1);
  EXPECT_EQ(st["subjects"][0]["state"], "done");
}

}  // namespace
}  // namespace haha
