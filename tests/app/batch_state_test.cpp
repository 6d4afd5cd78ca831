// The state logic of `haha batch` (app/batch_state.h, app/batch_run.h) without training:
// pending / running / interrupted / failed / done read from the subject folders, the lock,
// exit codes of bad input (written once, not retried), usage errors, a changed line.
#include "app/batch_state.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "app/batch_run.h"
#include "core/atomic_file.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

class BatchState : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("haha-batch-state-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "in" / "images");
    fs::create_directories(dir_ / "in" / "data");
    write_text_file((dir_ / "in" / "images" / "0.png").string(), "not really a png");
    write_text_file((dir_ / "in" / "data" / "dataset.json").string(), "{}");
    write_text_file((dir_ / "in" / "clip.mp4").string(), "x");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string manifest(const std::string& text) {
    const std::string p = (dir_ / "m.txt").string();
    write_text_file(p, text);
    return p;
  }
  BatchRunResult run(const std::string& m, int index) {
    BatchRunOptions o;
    o.manifest = m;
    o.root = root();
    o.index = index;
    o.log = [this](const std::string& l) { log_ += l + "\n"; };
    return run_batch_subject(o);
  }
  std::string root() const { return (dir_ / "out").string(); }
  fs::path dir_;
  std::string log_;
};

TEST_F(BatchState, InputKinds) {
  EXPECT_EQ(batch_input_kind((dir_ / "in" / "clip.mp4").string()), BatchInputKind::video);
  EXPECT_EQ(batch_input_kind((dir_ / "in" / "images").string()), BatchInputKind::images);
  EXPECT_EQ(batch_input_kind((dir_ / "in" / "data").string()), BatchInputKind::dataset);
  EXPECT_EQ(batch_input_kind((dir_ / "in" / "nothing").string()), BatchInputKind::missing);
  EXPECT_EQ(batch_input_kind((dir_ / "in").string()), BatchInputKind::unknown);  // no images, no dataset.json
}

TEST_F(BatchState, BadInputFailsOnceAndIsNotRetried) {
  const std::string m = manifest("missing in/nothing s1.steps=2\nbadline in/data s1.stepz=1\nempty in\n");
  const BatchManifest man = read_batch_manifest(m);
  SubjectStatus st = read_subject_status(man.subjects[0], root());
  EXPECT_EQ(st.state, SubjectState::pending);
  EXPECT_EQ(st.reason, "not started");
  EXPECT_NE(read_subject_status(man.subjects[1], root()).reason.find("bad manifest line"), std::string::npos);

  BatchRunResult r = run(m, 0);
  EXPECT_EQ(r.exit_code, kBatchBadInput);
  EXPECT_FALSE(r.skipped);
  EXPECT_NE(r.message.find("input not found"), std::string::npos) << r.message;
  const nlohmann::json f = nlohmann::json::parse(read_text_file(root() + "/missing/failed.json"));
  EXPECT_EQ(f["kind"], "bad_input");
  EXPECT_EQ(f["stage"], "input");
  EXPECT_EQ(f["attempts"], 1);
  EXPECT_EQ(f["exit_code"], 65);
  EXPECT_FALSE(fs::exists(root() + "/missing/running.json"));
  st = read_subject_status(man.subjects[0], root());
  EXPECT_EQ(st.state, SubjectState::failed);
  EXPECT_EQ(st.kind, "bad_input");
  EXPECT_NE(st.reason.find("input not found"), std::string::npos);

  // Again: not retried (same exit code, failed.json untouched), unless asked.
  r = run(m, 0);
  EXPECT_EQ(r.exit_code, kBatchBadInput);
  EXPECT_TRUE(r.skipped);
  EXPECT_NE(r.message.find("not retried"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(read_text_file(root() + "/missing/failed.json"))["attempts"], 1);
  BatchRunOptions o;
  o.manifest = m, o.root = root(), o.index = 0, o.retry_failed = true, o.log = [](const std::string&) {};
  EXPECT_EQ(run_batch_subject(o).exit_code, kBatchBadInput);
  EXPECT_EQ(nlohmann::json::parse(read_text_file(root() + "/missing/failed.json"))["attempts"], 2);

  // A bad option is that subject's bad input; a folder that is neither video, images nor dataset too.
  r = run(m, 1);
  EXPECT_EQ(r.exit_code, kBatchBadInput);
  EXPECT_NE(r.message.find("s1.stepz"), std::string::npos) << r.message;
  r = run(m, 2);
  EXPECT_EQ(r.exit_code, kBatchBadInput);
  EXPECT_NE(r.message.find("neither a video"), std::string::npos) << r.message;

  // Usage: index out of range, none given, manifest missing: exit 64, nothing written.
  EXPECT_EQ(run(m, 3).exit_code, kBatchUsage);
  unsetenv("SLURM_ARRAY_TASK_ID");
  unsetenv("JOB_COMPLETION_INDEX");
  EXPECT_EQ(run(m, -1).exit_code, kBatchUsage);
  setenv("JOB_COMPLETION_INDEX", "0", 1);
  EXPECT_EQ(run(m, -1).id, "missing");
  unsetenv("JOB_COMPLETION_INDEX");
  EXPECT_EQ(run((dir_ / "none.txt").string(), 0).exit_code, kBatchUsage);

  // The line fixed (another fingerprint): tried again.
  const std::string m2 = manifest("missing in/nothing-either s1.steps=2\n");
  r = run(m2, 0);
  EXPECT_FALSE(r.skipped);
  EXPECT_EQ(nlohmann::json::parse(read_text_file(root() + "/missing/failed.json"))["attempts"], 3);
}

TEST_F(BatchState, RunningInterruptedDoneAndTheLock) {
  const std::string m = manifest("a in/data\nb in/data\nc in/data\n");
  const BatchManifest man = read_batch_manifest(m);
  const SubjectPaths pa(root(), "a"), pb(root(), "b"), pc(root(), "c");
  for (const SubjectPaths* p : {&pa, &pb, &pc}) ensure_directory(p->dir);
  // a: running, its lock held (by this process: another open file description).
  nlohmann::json r = {{"host", host_name()}, {"pid", int(::getpid())}, {"stage", "train"},
                      {"progress", "[stage 1] step 3/40"}, {"attempt", 1}, {"heartbeat", unix_seconds()}, {"job", "slurm 5_0"}};
  write_text_file(pa.running(), r.dump());
  {
    FileLock lock(pa.lock());
    ASSERT_TRUE(lock.locked());
    EXPECT_TRUE(file_locked_by_other(pa.lock()));
    FileLock second(pa.lock());
    EXPECT_FALSE(second.locked());
    const SubjectStatus st = read_subject_status(man.subjects[0], root());
    EXPECT_EQ(st.state, SubjectState::running);
    EXPECT_EQ(st.kind, "train");
    EXPECT_NE(st.reason.find("step 3/40"), std::string::npos) << st.reason;
    EXPECT_NE(st.reason.find("slurm 5_0"), std::string::npos) << st.reason;
    // A task started on a busy subject exits retryable and leaves its state alone.
    BatchRunOptions o;
    o.manifest = m, o.root = root(), o.index = 0, o.log = [](const std::string&) {};
    const BatchRunResult busy = run_batch_subject(o);
    EXPECT_EQ(busy.exit_code, kBatchRetryable);
    EXPECT_NE(busy.message.find("busy"), std::string::npos);
    EXPECT_TRUE(fs::exists(pa.running()));
  }
  EXPECT_FALSE(file_locked_by_other(pa.lock()));
  // b: running.json of a task that is gone (a pid that does not exist, no lock): interrupted.
  r["pid"] = 999999999;
  r["heartbeat"] = unix_seconds() - 5;
  write_text_file(pb.running(), r.dump());
  SubjectStatus st = read_subject_status(man.subjects[1], root());
  EXPECT_EQ(st.state, SubjectState::failed);
  EXPECT_EQ(st.kind, "retryable");
  EXPECT_NE(st.reason.find("interrupted in train"), std::string::npos) << st.reason;
  // On another host, the heartbeat decides.
  r["host"] = "elsewhere";
  write_text_file(pb.running(), r.dump());
  EXPECT_EQ(read_subject_status(man.subjects[1], root()).state, SubjectState::running);
  r["heartbeat"] = unix_seconds() - 500;
  write_text_file(pb.running(), r.dump());
  EXPECT_EQ(read_subject_status(man.subjects[1], root()).state, SubjectState::failed);
  // c: done; a changed line marks it stale but it stays done.
  nlohmann::json d = {{"fingerprint", man.subjects[2].fingerprint()}, {"finished", "2026-11-25T20:00:00Z"},
                      {"avatar_bytes", 1234}, {"wall_seconds", 12.5}, {"attempts", 2}, {"psnr", 30.5}};
  write_text_file(pc.done(), d.dump());
  st = read_subject_status(man.subjects[2], root());
  EXPECT_EQ(st.state, SubjectState::done);
  EXPECT_FALSE(st.stale);
  EXPECT_EQ(st.attempts, 2);
  EXPECT_NE(st.reason.find("1234 B"), std::string::npos);
  EXPECT_NE(st.reason.find("30.50 dB"), std::string::npos);
  const BatchRunResult skip = run(m, 2);
  EXPECT_EQ(skip.exit_code, kBatchDone);
  EXPECT_TRUE(skip.skipped);
  EXPECT_NE(skip.message.find("already done"), std::string::npos);
  const BatchManifest changed = parse_batch_manifest("a in/data\nb in/data\nc in/data s1.steps=3\n", "m", dir_.string());
  EXPECT_TRUE(read_subject_status(changed.subjects[2], root()).stale);

  // The table and the JSON.
  std::vector<SubjectStatus> all;
  for (const BatchSubject& s : man.subjects) all.push_back(read_subject_status(s, root()));
  const std::string table = batch_status_table(all);
  EXPECT_NE(table.find("3 subjects: 1 done, 1 running, 1 failed, 0 pending"), std::string::npos) << table;
  const nlohmann::json j = nlohmann::json::parse(batch_status_json(all, m, root()));
  EXPECT_EQ(j["counts"]["done"], 1);
  EXPECT_EQ(j["subjects"][1]["state"], "failed");
  EXPECT_EQ(j["subjects"][1]["kind"], "retryable");
  EXPECT_EQ(j["subjects"][2]["seconds"], 12.5);
}

}  // namespace
}  // namespace haha
