#include "app/batch_state.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <signal.h>

#include "core/atomic_file.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

SubjectPaths::SubjectPaths(const std::string& root, const std::string& id) : dir((fs::path(root) / id).string()) {}
std::string SubjectPaths::file(const std::string& name) const { return (fs::path(dir) / name).string(); }

const char* subject_state_name(SubjectState s) {
  switch (s) {
    case SubjectState::pending: return "pending";
    case SubjectState::running: return "running";
    case SubjectState::done: return "done";
    case SubjectState::failed: return "failed";
  }
  return "?";
}

bool read_json_object(const std::string& path, ojson& j) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    j = ojson::parse(read_text_file(path));
    return j.is_object();
  } catch (const std::exception&) {
    return false;
  }
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

double unix_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

FileLock::FileLock(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return;
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return;
  }
  fd_ = fd;
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

bool file_locked_by_other(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

namespace {


std::string str(const ojson& j, const char* key) {
  return j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string();
}

}  // namespace

SubjectStatus read_subject_status(const BatchSubject& s, const std::string& root, double stale_after_s) {
  SubjectStatus st;
  st.index = s.index;
  st.id = s.id;
  if (s.id.empty()) {
    st.state = SubjectState::failed;
    st.kind = "bad_input";
    st.reason = s.error;
    return st;
  }
  const SubjectPaths p(root, s.id);
  ojson j;
  if (read_json_object(p.done(), j)) {
    st.state = SubjectState::done;
    st.attempts = j.value("attempts", 0);
    st.seconds = j.value("wall_seconds", 0.0);
    st.stale = str(j, "fingerprint") != s.fingerprint();
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s, %lld B, %.1f s", str(j, "finished").c_str(),
                  static_cast<long long>(j.value("avatar_bytes", 0)), st.seconds);
    st.reason = buf;
    if (j.contains("psnr") && j["psnr"].is_number()) {
      std::snprintf(buf, sizeof buf, ", PSNR %.2f dB", j["psnr"].get<double>());
      st.reason += buf;
    }
    if (st.stale) st.reason += " (the manifest line changed since; remove the folder to redo)";
    return st;
  }
  if (read_json_object(p.running(), j)) {
    const bool held = file_locked_by_other(p.lock());
    const double age = unix_seconds() - j.value("heartbeat", 0.0);
    const bool same_host = str(j, "host") == host_name();
    const bool pid_alive = same_host && j.value("pid", 0) > 0 && (::kill(j.value("pid", 0), 0) == 0 || errno == EPERM);
    st.attempts = j.value("attempt", 0);
    const std::string progress = str(j, "progress");
    if (held || (!same_host && age < stale_after_s) || (same_host && pid_alive && age < stale_after_s)) {
      st.state = SubjectState::running;
      st.kind = str(j, "stage");
      st.reason = str(j, "stage") + (progress.empty() ? "" : ": " + progress) + " (" + str(j, "host") +
                  (str(j, "job").empty() ? "" : ", job " + str(j, "job")) + ")";
      return st;
    }
    st.state = SubjectState::failed;
    st.kind = "retryable";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.0f", age);
    st.reason = "interrupted in " + str(j, "stage") + (progress.empty() ? "" : " (" + progress + ")") +
                ": the task is gone (last heartbeat " + buf + " s ago); run again to resume";
    return st;
  }
  if (read_json_object(p.failed(), j)) {
    st.state = SubjectState::failed;
    st.kind = str(j, "kind");
    st.reason = str(j, "stage") + ": " + str(j, "error");
    st.attempts = j.value("attempts", 0);
    st.stale = str(j, "fingerprint") != s.fingerprint();
    if (st.stale) st.reason += " (the manifest line changed since: the next run tries again)";
    return st;
  }
  if (!s.error.empty()) {
    st.state = SubjectState::pending;
    st.reason = "will fail, bad manifest line: " + s.error;
    return st;
  }
  std::error_code ec;
  st.reason = fs::exists(p.dir, ec) ? "started before, will resume" : "not started";
  return st;
}

std::string batch_status_table(const std::vector<SubjectStatus>& st) {
  size_t w = 2;
  for (const SubjectStatus& s : st) w = std::max(w, s.id.size());
  std::string out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "%5s  %-*s  %-8s  %-10s  %s\n", "index", int(w), "id", "state", "kind", "detail");
  out += buf;
  int counts[4] = {0, 0, 0, 0};
  for (const SubjectStatus& s : st) {
    ++counts[int(s.state)];
    std::snprintf(buf, sizeof buf, "%5d  %-*s  %-8s  %-10s  ", s.index, int(w), s.id.c_str(), subject_state_name(s.state),
                  s.kind.empty() ? "-" : s.kind.c_str());
    out += buf + s.reason + "\n";
  }
  std::snprintf(buf, sizeof buf, "%zu subjects: %d done, %d running, %d failed, %d pending\n", st.size(),
                counts[int(SubjectState::done)], counts[int(SubjectState::running)], counts[int(SubjectState::failed)],
                counts[int(SubjectState::pending)]);
  out += buf;
  return out;
}

std::string batch_status_json(const std::vector<SubjectStatus>& st, const std::string& manifest, const std::string& root) {
  ojson j;
  j["manifest"] = manifest;
  j["root"] = root;
  ojson counts = {{"done", 0}, {"running", 0}, {"failed", 0}, {"pending", 0}};
  ojson subjects = ojson::array();
  for (const SubjectStatus& s : st) {
    counts[subject_state_name(s.state)] = counts[subject_state_name(s.state)].get<int>() + 1;
    ojson e;
    e["index"] = s.index;
    e["id"] = s.id;
    e["state"] = subject_state_name(s.state);
    e["kind"] = s.kind.empty() ? ojson(nullptr) : ojson(s.kind);
    e["reason"] = s.reason;
    e["stale"] = s.stale;
    e["attempts"] = s.attempts;
    if (s.state == SubjectState::done) e["seconds"] = s.seconds;
    subjects.push_back(e);
  }
  j["counts"] = counts;
  j["subjects"] = subjects;
  return j.dump(2) + "\n";
}

}  // namespace haha
