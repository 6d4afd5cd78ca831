// The state of one batch subject, kept in its folder ROOT/ID (`haha batch`, docs/scale-out.md):
//
//   ROOT/ID/data/           the dataset `haha fit-video` made (video or image-folder inputs)
//   ROOT/ID/run/            the training run (app/run_dir.h; eval's report.json in it)
//   ROOT/ID/avatar.glb      the packed avatar
//   ROOT/ID/log.txt         every attempt's progress lines, appended
//   ROOT/ID/running.json    while a task works on it: host, pid, job, stage, last progress line,
//                           heartbeat (rewritten every few seconds); removed when it ends
//   ROOT/ID/done.json       written last: the subject is done (times, sizes, metrics)
//   ROOT/ID/failed.json     why the last attempt failed: kind bad_input (not retried) or
//                           retryable (the next run resumes)
//   ROOT/ID/.lock           flock()ed by the task working on the subject
// Every JSON file is written atomically (core/atomic_file.h).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/batch_manifest.h"

namespace haha {

// Exit codes of `haha batch run` (sysexits.h values, so schedulers can match them).
enum BatchExit : int {
  kBatchDone = 0,        // done now, or already done (skipped)
  kBatchUsage = 64,      // no index / index out of range / unreadable manifest: nothing written
  kBatchBadInput = 65,   // the subject's input or line is bad: do not retry (failed.json)
  kBatchRetryable = 75,  // interrupted, out of memory, I/O, busy: run again, it resumes (failed.json)
};

struct SubjectPaths {
  std::string dir;
  SubjectPaths(const std::string& root, const std::string& id);
  std::string file(const std::string& name) const;
  std::string data() const { return file("data"); }
  std::string run() const { return file("run"); }
  std::string avatar() const { return file("avatar.glb"); }
  std::string log() const { return file("log.txt"); }
  std::string running() const { return file("running.json"); }
  std::string done() const { return file("done.json"); }
  std::string failed() const { return file("failed.json"); }
  std::string lock() const { return file(".lock"); }
};

enum class SubjectState { pending, running, done, failed };
const char* subject_state_name(SubjectState s);

struct SubjectStatus {
  int index = -1;
  std::string id;
  SubjectState state = SubjectState::pending;
  std::string kind;      // failed: bad_input | retryable; running: the stage
  std::string reason;    // one line
  bool stale = false;    // done / failed for another manifest line than the current one
  int attempts = 0;
  double seconds = 0;    // done: wall seconds of the attempts
};

// The state of subject `s` under `root`. A running.json whose task is gone (its lock is
// free, or no heartbeat for `stale_after_s`) reads as failed, retryable (interrupted).
SubjectStatus read_subject_status(const BatchSubject& s, const std::string& root, double stale_after_s = 120);

std::string batch_status_table(const std::vector<SubjectStatus>& st);
std::string batch_status_json(const std::vector<SubjectStatus>& st, const std::string& manifest, const std::string& root);

// An exclusive flock() on `path` (created). locked() is false when another process holds it.
class FileLock {
 public:
  explicit FileLock(const std::string& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  bool locked() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};
// True when some process holds the lock on `path` (a momentary shared-lock probe).
bool file_locked_by_other(const std::string& path);

// The JSON object in `path`; false (j untouched or partial) when the file is missing, unreadable
// or not an object: a state file half-written by a killed task counts as absent.
bool read_json_object(const std::string& path, nlohmann::ordered_json& j);

std::string host_name();
std::string utc_now();        // 2026-11-25T19:40:01Z
double unix_seconds();

}  // namespace haha
