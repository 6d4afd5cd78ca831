#include "app/batch_run.h"

#include <unistd.h>

#include <cctype>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <new>
#include <nlohmann/json.hpp>
#include <thread>

#include "app/eval_run.h"
#include "app/fit_video_run.h"
#include "app/keypoint_tool.h"
#include "app/pack_run.h"
#include "app/run_dir.h"
#include "app/train_run.h"
#include "fit/fit_video.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "format/avatar_unpack.h"
#include "format/image_codec.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

BatchInputKind batch_input_kind(const std::string& path) {
  std::error_code ec;
  if (path.empty() || !fs::exists(path, ec)) return BatchInputKind::missing;
  if (fs::is_regular_file(path, ec)) return BatchInputKind::video;
  if (!fs::is_directory(path, ec)) return BatchInputKind::unknown;
  if (fs::exists(fs::path(path) / "dataset.json", ec)) return BatchInputKind::dataset;
  for (const auto& e : fs::directory_iterator(path, ec)) {
    std::string ext = e.path().extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg")) return BatchInputKind::images;
  }
  return BatchInputKind::unknown;
}

const char* batch_input_kind_name(BatchInputKind k) {
  switch (k) {
    case BatchInputKind::missing: return "missing";
    case BatchInputKind::video: return "video";
    case BatchInputKind::images: return "images";
    case BatchInputKind::dataset: return "dataset";
    case BatchInputKind::unknown: return "unknown";
  }
  return "?";
}

namespace {

// A failure of one stage, classified.
struct StageFailure {
  bool bad_input = false;
  std::string stage, error;
};

std::string job_name() {
  auto env = [](const char* k) {
    const char* v = std::getenv(k);
    return std::string(v ? v : "");
  };
  if (!env("SLURM_ARRAY_JOB_ID").empty())
    return "slurm " + env("SLURM_ARRAY_JOB_ID") + "_" + env("SLURM_ARRAY_TASK_ID") + " (job " + env("SLURM_JOB_ID") + ")";
  if (!env("SLURM_JOB_ID").empty()) return "slurm " + env("SLURM_JOB_ID");
  if (!env("JOB_COMPLETION_INDEX").empty()) return "k8s pod " + host_name() + " index " + env("JOB_COMPLETION_INDEX");
  return "";
}

// running.json, rewritten by a heartbeat thread while the subject is worked on.
class Heartbeat {
 public:
  Heartbeat(std::string path, ojson base, double every_s) : path_(std::move(path)), base_(std::move(base)) {
    write();
    thread_ = std::thread([this, every_s] {
      std::unique_lock<std::mutex> lk(m_);
      while (!stop_) {
        cv_.wait_for(lk, std::chrono::duration<double>(every_s));
        if (stop_) break;
        lk.unlock();
        write();
        lk.lock();
      }
    });
  }
  ~Heartbeat() {
    {
      std::lock_guard<std::mutex> lk(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
    std::error_code ec;
    fs::remove(path_, ec);
  }
  void set_stage(const std::string& stage) {
    {
      std::lock_guard<std::mutex> lk(m_);
      base_["stage"] = stage;
      base_["progress"] = "";
    }
    write();
  }
  void set_progress(const std::string& line) {
    std::lock_guard<std::mutex> lk(m_);
    base_["progress"] = line;
  }

 private:
  void write() {
    std::string text;
    {
      std::lock_guard<std::mutex> lk(m_);
      base_["heartbeat"] = unix_seconds();
      base_["heartbeat_utc"] = utc_now();
      text = base_.dump(2) + "\n";
    }
    try {
      write_text_file(path_, text);
    } catch (const std::exception&) {  // a heartbeat that cannot be written is not the task's failure
    }
  }
  std::string path_;
  ojson base_;
  std::mutex m_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};


const std::string* opt_get(const std::vector<std::pair<std::string, std::string>>& kv, const std::string& key) {
  const std::string* r = nullptr;
  for (const auto& [k, v] : kv)
    if (k == key) r = &v;
  return r;
}

using LogFn = std::function<void(const std::string&)>;

// The manifest's subject for this task; false when there is none and `res` says why.
bool pick_subject(const BatchRunOptions& opt, BatchManifest& manifest, BatchRunResult& res) {
  try {
    if (opt.root.empty()) fail("--out", "no output root given");
    manifest = read_batch_manifest(opt.manifest);
    res.index = batch_task_index(opt.index, [](const char* k) -> const char* { return std::getenv(k); });
  } catch (const std::exception& e) {
    res.exit_code = kBatchUsage;
    res.message = e.what();
    return false;
  }
  if (res.index < 0) {
    res.exit_code = kBatchUsage;
    res.message = "--index: not given, and neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set";
    return false;
  }
  if (res.index >= int(manifest.subjects.size())) {
    res.exit_code = kBatchUsage;
    res.message = opt.manifest + ": index " + std::to_string(res.index) + " out of range (" +
                  std::to_string(manifest.subjects.size()) + " subjects, indices 0.." +
                  std::to_string(int(manifest.subjects.size()) - 1) + ")";
    return false;
  }
  const BatchSubject& s = manifest.subjects[res.index];
  res.id = s.id;
  if (s.id.empty() || s.error.find("id '") != std::string::npos) {  // no folder to write failed.json into
    res.exit_code = kBatchBadInput;
    res.message = s.error;
    return false;
  }
  return true;
}

// What the earlier attempts left in the subject's folder.
struct PreviousAttempts {
  int attempts = 0;
  bool had_failed = false;
  ojson failed;  // failed.json, when had_failed
};

// False when the subject is done, not to be retried or started for another line (`res` says
// which); else the earlier attempts, with a folder left by a since-fixed bad line cleared.
bool check_previous_attempts(const BatchRunOptions& opt, const BatchSubject& s, const SubjectPaths& p,
                             PreviousAttempts& prev, BatchRunResult& res) {
  ojson done;
  if (read_json_object(p.done(), done)) {
    res.skipped = true;
    res.message = s.id + ": already done (" + p.done() + ")";
    if (done.value("fingerprint", "") != s.fingerprint())
      res.message += "; note: its manifest line changed since, remove " + p.dir + " to redo it";
    return false;
  }
  prev.had_failed = read_json_object(p.failed(), prev.failed);
  if (prev.had_failed) {
    prev.attempts = prev.failed.value("attempts", 0);
    const bool same = prev.failed.value("fingerprint", "") == s.fingerprint();
    if (prev.failed.value("kind", "") == "bad_input" && same && !opt.retry_failed) {
      res.skipped = true;
      res.exit_code = kBatchBadInput;
      res.message = s.id + ": bad input, not retried: " + prev.failed.value("error", "") + " (" + p.failed() +
                    "; change the line or pass --retry-failed)";
      return false;
    }
  }
  ojson running_prev;
  if (read_json_object(p.running(), running_prev))
    prev.attempts = std::max(prev.attempts, running_prev.value("attempt", 0));
  // A folder started for another manifest line is not mixed with this one, unless that
  // attempt ended as bad input (the line was fixed).
  ojson started;
  if (read_json_object(p.file("subject.json"), started) && started.value("fingerprint", "") != s.fingerprint()) {
    if (prev.had_failed && prev.failed.value("kind", "") == "bad_input") {
      std::error_code ec;
      fs::remove_all(p.data(), ec);
      fs::remove_all(p.run(), ec);
      fs::remove(p.avatar(), ec);
    } else {
      res.exit_code = kBatchBadInput;
      res.message = p.dir + ": started for another manifest line (" + started.value("line", "") +
                    "); remove the folder to start it again with this one";
      return false;  // nothing written: the folder's own state stays as it was
    }
  }
  return true;
}

void write_subject_json(const BatchRunOptions& opt, const BatchSubject& s, const SubjectPaths& p,
                        const std::string& line_text) {
  ojson sj;
  sj["id"] = s.id;
  sj["fingerprint"] = s.fingerprint();
  sj["line"] = line_text;
  sj["manifest"] = fs::absolute(opt.manifest).lexically_normal().string();
  write_text_file(p.file("subject.json"), sj.dump(2) + "\n");
}

ojson running_json(const BatchSubject& s, const std::string& job, int attempts) {
  ojson rj;
  rj["id"] = s.id;
  rj["index"] = s.index;
  rj["host"] = host_name();
  rj["pid"] = int(::getpid());
  rj["job"] = job;
  rj["attempt"] = attempts;
  rj["started"] = utc_now();
  rj["stage"] = "input";
  rj["progress"] = "";
  return rj;
}

// What the stages of one attempt share. `enter` starts a stage (and is where an interrupt
// stops the attempt); `done` gathers what done.json records of the stages.
struct StageContext {
  const BatchRunOptions& opt;
  const BatchSubject& s;
  const SubjectPaths& p;
  const LogFn& log;
  const LogFn& enter;
  ojson& done;
};

void fit_video_stage(const StageContext& c, const std::string& data) {
  FitVideoRunOptions fo;
  fo.input = c.s.input_path;
  fo.out = data;
  fo.keypoint_tool = c.opt.keypoint_tool;
  for (const auto& [k, v] : c.s.fit) {
    if (k == "fps") fo.fps = std::stod(v);
    if (k == "test-every") fo.test_every = std::stoi(v);
    if (k == "test-from") fo.test_from = std::stoi(v);
    if (k == "focal") fo.focal_px = std::stod(v);
    if (k == "focal-35mm") fo.focal_35mm = std::stod(v);
    if (k == "fov") fo.fov_deg = std::stod(v), fo.fov_given = true;
    if (k == "frames") fo.frames = v;
    if (k == "mask") fo.mask = v;
    if (k == "keypoints") fo.keypoints = v;
    if (k == "robust-smoothness") fo.robust_smoothness = std::stod(v);
  }
  validate_fit_video_options(fo);
  try {
    check_keypoint_tool(find_keypoint_tool(c.opt.keypoint_tool));
  } catch (const std::exception& e) {  // the machine's problem, not the subject's
    throw std::runtime_error(std::string("keypoint tool: ") + e.what());
  }
  const BodyModel body = synth_body(c.s.model, BodyResolution::full, 0);
  fo.save_body = c.s.model.empty();
  const FitVideoSummary fs_ = run_fit_video(fo, body, [&body](const std::vector<FitVideoInputFrame>& frames,
                                                              const FitVideoOptions& vo) {
    return fit_video(body, frames, vo);
  });
  char buf[200];
  std::snprintf(buf, sizeof buf, "fit-video: %d frames kept (%d train, %d test), %d dropped; keypoint error %.2f px",
                fs_.kept, fs_.train, fs_.test, fs_.dropped, fs_.mean_reprojection_px);
  c.log(buf);
}

// The dataset to train on: the input itself, or the one fit-video makes of a video or an
// image folder.
std::string dataset_stage(const StageContext& c, BatchInputKind kind) {
  if (kind != BatchInputKind::video && kind != BatchInputKind::images) return c.s.input_path;
  const std::string data = c.p.data();
  if (!fs::exists(fs::path(data) / "dataset.json")) {
    c.enter("fit-video");
    fit_video_stage(c, data);
  } else {
    c.log("fit-video: done before (" + data + ")");
  }
  return data;
}

// The dataset's test frames; it is read (headers only) before training to fail early.
int validate_stage(const std::string& data) {
  const Dataset ds = read_dataset(data, LoadPixels::headers);
  if (ds.indices(Split::train).empty()) fail(data, "the dataset has no training frames");
  return int(ds.indices(Split::test).size());
}

void train_stage(const StageContext& c, const RunDir& run, const std::string& data, bool& train_started) {
  if (fs::exists(run.avatar()) && fs::exists(run.train_summary())) {
    c.log("train: done before (" + run.dir + ")");
    return;
  }
  c.enter("train");
  TrainRunOptions to;
  to.data_dir = data;
  to.run_dir = run.dir;
  to.model_path = c.s.model;
  to.preset = c.s.preset;
  to.device = c.s.device;
  to.resume = fs::exists(run.checkpoint()) && fs::exists(run.config());
  if (!to.resume) to.overrides = c.s.train_overrides;
  else to.data_dir.clear();
  to.log = [&](const std::string& l) {
    if (l.rfind("training ", 0) == 0 || l.rfind("resumed ", 0) == 0 || l.rfind("[stage", 0) == 0) train_started = true;
    c.log(l);
  };
  const TrainRunResult tr = run_training(to);
  if (!tr.finished) throw std::runtime_error("training stopped before its end");
  c.done["resumed"] = to.resume;
}

void eval_stage(const StageContext& c, const RunDir& run, int test_frames) {
  const std::string* split = opt_get(c.s.eval, "split");
  const std::string sp = split ? *split : "test";
  if (sp == "none" || (sp == "test" && test_frames == 0)) {
    c.done["eval"] = sp == "none" ? "skipped (eval:split=none)" : "skipped (the dataset has no test frames)";
  } else if (!fs::exists(run.report_json())) {
    c.enter("eval");
    EvalRunOptions eo;
    eo.run_dir = run.dir;
    eo.split = sp;
    eo.print_table = false;
    if (const std::string* v = opt_get(c.s.eval, "antialias")) eo.antialias = *v == "true" ? 1 : 0;  // else the run's
    if (const std::string* v = opt_get(c.s.eval, "tto-steps")) eo.tto_steps = std::stoi(*v);
    if (const std::string* v = opt_get(c.s.eval, "frames")) eo.frames = std::stoi(*v);
    if (const std::string* v = opt_get(c.s.eval, "background")) eo.background = *v;
    const EvalReport rep = run_eval(eo);
    if (!rep.variants.empty()) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "eval: %s PSNR %.2f dB, SSIM %.4f (%zu %s frames, %.1f s)",
                    rep.variants.back().name.c_str(), rep.variants.back().psnr, rep.variants.back().ssim,
                    rep.frame_names.size(), sp.c_str(), rep.eval_seconds);
      c.log(buf);
    }
  } else {
    c.log("eval: done before (" + run.report_json() + ")");
  }
  ojson report;
  if (read_json_object(run.report_json(), report))
    c.done["report"] = fs::absolute(run.report_json()).lexically_normal().string();
}

void pack_stage(const StageContext& c, const RunDir& run) {
  if (fs::exists(c.p.avatar())) {
    c.log("pack: done before (" + c.p.avatar() + ")");
    return;
  }
  c.enter("pack");
  PackOptions po;
  for (const auto& [k, v] : c.s.pack) {
    if (k == "mesh-compression") po.mesh_compression = v == "none" ? MeshCompression::none : MeshCompression::draco;
    if (k == "texture") po.texture_codec = texture_codec_from_name(v);
    if (k == "texture-size") po.texture_size = std::stoi(v);
    if (k == "texture-quality") po.texture_quality = std::stoi(v);
    if (k == "lod") po.lod_tiers = std::stoi(v);
    if (k == "lossless") po.lossless = v == "true";
    if (k == "khr-gaussian-splatting") po.khr_gaussian_splatting = v == "true";
    if (k == "normals") po.normals = v == "true";
    if (k == "keep-face-order") po.keep_face_order = v == "true";
  }
  const PackedSizes ps = pack_run(run.dir, c.s.model, c.p.avatar(), po);
  c.log("pack: " + c.p.avatar() + ": " + std::to_string(ps.total) + " bytes, " + std::to_string(ps.num_gaussians) +
        " Gaussians");
}

// The packed avatar reads back; its size and the report's PSNR go into done.json.
void check_stage(const StageContext& c, const RunDir& run) {
  const UnpackedAvatar back = read_avatar_file(c.p.avatar());
  c.done["gaussians"] = back.avatar.gaussians.size();
  c.done["avatar_bytes"] = fs::file_size(c.p.avatar());
  ojson report;
  if (read_json_object(run.report_json(), report) && report.contains("variants") && report["variants"].is_array() &&
      !report["variants"].empty()) {
    const ojson& v = report["variants"].back();
    if (v.contains("psnr")) c.done["psnr"] = v["psnr"];
  }
}

// Every stage in turn; one whose output is already there is skipped, so a retry resumes.
void run_stages(const StageContext& c, bool& train_started) {
  if (!c.s.error.empty()) fail(c.s.input.empty() ? c.opt.manifest : c.s.input, c.s.error);
  const BatchInputKind kind = batch_input_kind(c.s.input_path);
  if (kind == BatchInputKind::missing) fail(c.s.input_path, "input not found");
  if (kind == BatchInputKind::unknown)
    fail(c.s.input_path, "neither a video file, a folder of .png/.jpg images nor a dataset (no dataset.json)");
  c.done["input_kind"] = batch_input_kind_name(kind);
  const std::string data = dataset_stage(c, kind);
  c.enter("validate");
  const int test_frames = validate_stage(data);
  const RunDir run(c.p.run());
  train_stage(c, run, data, train_started);
  train_started = true;
  eval_stage(c, run, test_frames);
  pack_stage(c, run);
  c.enter("check");
  check_stage(c, run);
}

StageFailure classify_failure(const std::exception& e, const std::string& stage, bool train_started) {
  StageFailure failure;
  failure.stage = stage;
  failure.error = e.what();
  const Error* he = dynamic_cast<const Error*>(&e);
  // haha::Error is the project's bad-input error (one line naming the file). Interrupts,
  // out of memory, file-system errors and failures after training started are retryable.
  failure.bad_input = he && !interrupted() && !(stage == "train" && train_started);
  if (dynamic_cast<const std::bad_alloc*>(&e)) failure.error = "out of memory (std::bad_alloc)";
  return failure;
}

// What one attempt was, for done.json and failed.json.
struct AttemptRecord {
  std::string line_text, job;
  int attempts = 0;
  double wall = 0;
};

// done.json; false with `failure` set when it cannot be written.
bool write_done_json(const BatchSubject& s, const SubjectPaths& p, const AttemptRecord& a,
                     const PreviousAttempts& prev, const ojson& done, StageFailure& failure) {
  double total = a.wall;
  if (prev.had_failed) total += prev.failed.value("wall_seconds", 0.0);
  ojson d;
  d["id"] = s.id;
  d["index"] = s.index;
  d["fingerprint"] = s.fingerprint();
  d["line"] = a.line_text;
  d["finished"] = utc_now();
  d["host"] = host_name();
  d["job"] = a.job;
  d["attempts"] = a.attempts;
  d["wall_seconds"] = total;
  d["last_attempt_seconds"] = a.wall;
  d["avatar"] = fs::absolute(p.avatar()).lexically_normal().string();
  for (auto it = done.begin(); it != done.end(); ++it) d[it.key()] = it.value();
  try {
    write_text_file(p.done(), d.dump(2) + "\n");
  } catch (const std::exception& e) {
    failure.stage = "done";
    failure.error = e.what();
    return false;
  }
  return true;
}

void write_failed_json(const BatchSubject& s, const SubjectPaths& p, const AttemptRecord& a,
                       const PreviousAttempts& prev, const StageFailure& failure) {
  ojson f;
  f["id"] = s.id;
  f["index"] = s.index;
  f["kind"] = failure.bad_input ? "bad_input" : "retryable";
  f["stage"] = failure.stage;
  f["error"] = failure.error;
  f["exit_code"] = failure.bad_input ? int(kBatchBadInput) : int(kBatchRetryable);
  f["attempts"] = a.attempts;
  f["fingerprint"] = s.fingerprint();
  f["line"] = a.line_text;
  f["time"] = utc_now();
  f["host"] = host_name();
  f["job"] = a.job;
  f["wall_seconds"] = a.wall + (prev.had_failed ? prev.failed.value("wall_seconds", 0.0) : 0.0);
  f["hint"] = failure.bad_input ? "fix the input or the manifest line; the subject is not retried with the same line"
                                : "run the same index again: it resumes";
  try {
    write_text_file(p.failed(), f.dump(2) + "\n");
  } catch (const std::exception&) {
  }
}

}  // namespace

BatchRunResult run_batch_subject(const BatchRunOptions& opt) {
  BatchRunResult res;
  auto out = [&](const std::string& s) {
    if (opt.log)
      opt.log(s);
    else {
      std::printf("%s\n", s.c_str());
      std::fflush(stdout);
    }
  };
  BatchManifest manifest;
  if (!pick_subject(opt, manifest, res)) return res;
  const BatchSubject& s = manifest.subjects[res.index];
  const SubjectPaths p(opt.root, s.id);
  try {
    ensure_directory(p.dir);
  } catch (const std::exception& e) {
    res.exit_code = kBatchRetryable;
    res.message = e.what();
    return res;
  }
  FileLock lock(p.lock());
  if (!lock.locked()) {
    res.exit_code = kBatchRetryable;
    res.message = p.lock() + ": another task is working on " + s.id + " (busy)";
    return res;
  }
  PreviousAttempts prev;
  if (!check_previous_attempts(opt, s, p, prev, res)) return res;
  AttemptRecord a;
  a.attempts = prev.attempts + 1;
  a.job = job_name();
  const auto t0 = std::chrono::steady_clock::now();
  std::ofstream logf(p.log(), std::ios::app);
  std::mutex log_mutex;
  LogFn heartbeat_progress;
  const LogFn log = [&](const std::string& line) {
    std::lock_guard<std::mutex> lk(log_mutex);
    out("[" + s.id + "] " + line);
    logf << utc_now() << " " << line << "\n";
    logf.flush();
    if (heartbeat_progress) heartbeat_progress(line);
  };
  a.line_text = s.id + " " + s.input;
  for (const auto& [k, v] : s.options) a.line_text += " " + k + "=" + v;
  try {
    write_subject_json(opt, s, p, a.line_text);
  } catch (const std::exception& e) {
    res.exit_code = kBatchRetryable;
    res.message = e.what();
    return res;
  }
  log("attempt " + std::to_string(a.attempts) + " on " + host_name() + (a.job.empty() ? "" : ", " + a.job) + ": " +
      a.line_text);

  install_interrupt_handler();  // SIGTERM (scancel, pod deletion): checkpoint, failed.json retryable
  StageFailure failure;
  ojson done;
  {
    Heartbeat hb(p.running(), running_json(s, a.job, a.attempts), opt.heartbeat_s);
    heartbeat_progress = [&hb](const std::string& l) { hb.set_progress(l); };
    std::string stage = "input";
    bool train_started = false;
    const LogFn enter = [&](const std::string& st) {
      check_interrupted();
      stage = st;
      hb.set_stage(st);
    };
    try {
      run_stages({opt, s, p, log, enter, done}, train_started);
    } catch (const std::exception& e) {
      failure = classify_failure(e, stage, train_started);
    }
    heartbeat_progress = nullptr;
  }  // running.json removed
  a.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::error_code ec;
  if (failure.stage.empty() && write_done_json(s, p, a, prev, done, failure)) {
    fs::remove(p.failed(), ec);
    char buf[96];
    std::snprintf(buf, sizeof buf, " (attempt %d, %.1f s)", a.attempts, a.wall);
    log(std::string("done: ") + p.avatar() + buf);
    res.message = s.id + ": done" + buf;
    return res;
  }
  write_failed_json(s, p, a, prev, failure);
  log(std::string(failure.bad_input ? "bad input" : "failed (retryable)") + " in " + failure.stage + ": " +
      failure.error);
  res.exit_code = failure.bad_input ? kBatchBadInput : kBatchRetryable;
  res.message = s.id + ": " + (failure.bad_input ? "bad input" : "retryable failure") + " in " + failure.stage + ": " +
                failure.error;
  return res;
}

}  // namespace haha
