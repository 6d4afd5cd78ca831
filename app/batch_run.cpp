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
  // ---- which subject ---------------------------------------------------------------------
  BatchManifest manifest;
  try {
    if (opt.root.empty()) fail("--out", "no output root given");
    manifest = read_batch_manifest(opt.manifest);
    res.index = batch_task_index(opt.index, [](const char* k) -> const char* { return std::getenv(k); });
  } catch (const std::exception& e) {
    res.exit_code = kBatchUsage;
    res.message = e.what();
    return res;
  }
  if (res.index < 0) {
    res.exit_code = kBatchUsage;
    res.message = "--index: not given, and neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set";
    return res;
  }
  if (res.index >= int(manifest.subjects.size())) {
    res.exit_code = kBatchUsage;
    res.message = opt.manifest + ": index " + std::to_string(res.index) + " out of range (" +
                  std::to_string(manifest.subjects.size()) + " subjects, indices 0.." +
                  std::to_string(int(manifest.subjects.size()) - 1) + ")";
    return res;
  }
  const BatchSubject& s = manifest.subjects[res.index];
  res.id = s.id;
  if (s.id.empty() || s.error.find("id '") != std::string::npos) {  // no folder to write failed.json into
    res.exit_code = kBatchBadInput;
    res.message = s.error;
    return res;
  }
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
  // ---- done, or not to be retried --------------------------------------------------------
  ojson prev;
  if (read_json_object(p.done(), prev)) {
    res.skipped = true;
    res.message = s.id + ": already done (" + p.done() + ")";
    if (prev.value("fingerprint", "") != s.fingerprint())
      res.message += "; note: its manifest line changed since, remove " + p.dir + " to redo it";
    return res;
  }
  int attempts = 0;
  const bool had_failed = read_json_object(p.failed(), prev);
  if (had_failed) {
    attempts = prev.value("attempts", 0);
    const bool same = prev.value("fingerprint", "") == s.fingerprint();
    if (prev.value("kind", "") == "bad_input" && same && !opt.retry_failed) {
      res.skipped = true;
      res.exit_code = kBatchBadInput;
      res.message = s.id + ": bad input, not retried: " + prev.value("error", "") + " (" + p.failed() +
                    "; change the line or pass --retry-failed)";
      return res;
    }
  }
  ojson running_prev;
  if (read_json_object(p.running(), running_prev)) attempts = std::max(attempts, running_prev.value("attempt", 0));
  // A folder started for another manifest line is not mixed with this one, unless that
  // attempt ended as bad input (the line was fixed).
  const std::string subject_json = p.file("subject.json");
  ojson started;
  if (read_json_object(subject_json, started) && started.value("fingerprint", "") != s.fingerprint()) {
    if (had_failed && prev.value("kind", "") == "bad_input") {
      std::error_code ec;
      fs::remove_all(p.data(), ec);
      fs::remove_all(p.run(), ec);
      fs::remove(p.avatar(), ec);
    } else {
      res.exit_code = kBatchBadInput;
      res.message = p.dir + ": started for another manifest line (" + started.value("line", "") +
                    "); remove the folder to start it again with this one";
      return res;  // nothing written: the folder's own state stays as it was
    }
  }
  ++attempts;
  const std::string job = job_name();
  const auto t0 = std::chrono::steady_clock::now();
  std::ofstream logf(p.log(), std::ios::app);
  std::mutex log_mutex;
  std::function<void(const std::string&)> heartbeat_progress;
  auto log = [&](const std::string& line) {
    std::lock_guard<std::mutex> lk(log_mutex);
    out("[" + s.id + "] " + line);
    logf << utc_now() << " " << line << "\n";
    logf.flush();
    if (heartbeat_progress) heartbeat_progress(line);
  };
  std::string line_text = s.id + " " + s.input;
  for (const auto& [k, v] : s.options) line_text += " " + k + "=" + v;
  try {
    ojson sj;
    sj["id"] = s.id;
    sj["fingerprint"] = s.fingerprint();
    sj["line"] = line_text;
    sj["manifest"] = fs::absolute(opt.manifest).lexically_normal().string();
    write_text_file(subject_json, sj.dump(2) + "\n");
  } catch (const std::exception& e) {
    res.exit_code = kBatchRetryable;
    res.message = e.what();
    return res;
  }
  log("attempt " + std::to_string(attempts) + " on " + host_name() + (job.empty() ? "" : ", " + job) + ": " + line_text);

  install_interrupt_handler();  // SIGTERM (scancel, pod deletion): checkpoint, failed.json retryable
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
  StageFailure failure;
  ojson done;
  {
    Heartbeat hb(p.running(), rj, opt.heartbeat_s);
    heartbeat_progress = [&hb](const std::string& l) { hb.set_progress(l); };
    std::string stage = "input";
    bool train_started = false;
    auto enter = [&](const std::string& st) {
      check_interrupted();
      stage = st;
      hb.set_stage(st);
    };
    try {
      if (!s.error.empty()) fail(s.input.empty() ? opt.manifest : s.input, s.error);
      const BatchInputKind kind = batch_input_kind(s.input_path);
      if (kind == BatchInputKind::missing) fail(s.input_path, "input not found");
      if (kind == BatchInputKind::unknown)
        fail(s.input_path, "neither a video file, a folder of .png/.jpg images nor a dataset (no dataset.json)");
      std::string data = s.input_path;
      done["input_kind"] = batch_input_kind_name(kind);
      // ---- fit-video ----
      if (kind == BatchInputKind::video || kind == BatchInputKind::images) {
        data = p.data();
        if (!fs::exists(fs::path(data) / "dataset.json")) {
          enter("fit-video");
          FitVideoRunOptions fo;
          fo.input = s.input_path;
          fo.out = data;
          fo.keypoint_tool = opt.keypoint_tool;
          for (const auto& [k, v] : s.fit) {
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
            check_keypoint_tool(find_keypoint_tool(opt.keypoint_tool));
          } catch (const std::exception& e) {  // the machine's problem, not the subject's
            throw std::runtime_error(std::string("keypoint tool: ") + e.what());
          }
          const BodyModel body = synth_body(s.model, BodyResolution::full, 0);
          fo.save_body = s.model.empty();
          const FitVideoSummary fs_ = run_fit_video(fo, body, [&body](const std::vector<FitVideoInputFrame>& frames,
                                                                      const FitVideoOptions& vo) {
            return fit_video(body, frames, vo);
          });
          char buf[200];
          std::snprintf(buf, sizeof buf, "fit-video: %d frames kept (%d train, %d test), %d dropped; keypoint error %.2f px",
                        fs_.kept, fs_.train, fs_.test, fs_.dropped, fs_.mean_reprojection_px);
          log(buf);
        } else {
          log("fit-video: done before (" + data + ")");
        }
      }
      // ---- validate the dataset before training ----
      enter("validate");
      int test_frames = 0;
      {
        const Dataset ds = read_dataset(data, LoadPixels::headers);
        if (ds.indices(Split::train).empty()) fail(data, "the dataset has no training frames");
        test_frames = int(ds.indices(Split::test).size());
      }
      // ---- train ----
      const RunDir run(p.run());
      if (!(fs::exists(run.avatar()) && fs::exists(run.train_summary()))) {
        enter("train");
        TrainRunOptions to;
        to.data_dir = data;
        to.run_dir = run.dir;
        to.model_path = s.model;
        to.preset = s.preset;
        to.device = s.device;
        to.resume = fs::exists(run.checkpoint()) && fs::exists(run.config());
        if (!to.resume) to.overrides = s.train_overrides;
        else to.data_dir.clear();
        to.log = [&](const std::string& l) {
          if (l.rfind("training ", 0) == 0 || l.rfind("resumed ", 0) == 0 || l.rfind("[stage", 0) == 0) train_started = true;
          log(l);
        };
        const TrainRunResult tr = run_training(to);
        if (!tr.finished) throw std::runtime_error("training stopped before its end");
        done["resumed"] = to.resume;
      } else {
        log("train: done before (" + run.dir + ")");
      }
      train_started = true;
      // ---- eval ----
      const std::string* split = opt_get(s.eval, "split");
      const std::string sp = split ? *split : "test";
      if (sp == "none" || (sp == "test" && test_frames == 0)) {
        done["eval"] = sp == "none" ? "skipped (eval:split=none)" : "skipped (the dataset has no test frames)";
      } else if (!fs::exists(run.report_json())) {
        enter("eval");
        EvalRunOptions eo;
        eo.run_dir = run.dir;
        eo.split = sp;
        eo.print_table = false;
        if (const std::string* v = opt_get(s.eval, "antialias")) eo.antialias = *v == "true" ? 1 : 0;  // else the run's
        if (const std::string* v = opt_get(s.eval, "tto-steps")) eo.tto_steps = std::stoi(*v);
        if (const std::string* v = opt_get(s.eval, "frames")) eo.frames = std::stoi(*v);
        if (const std::string* v = opt_get(s.eval, "background")) eo.background = *v;
        const EvalReport rep = run_eval(eo);
        if (!rep.variants.empty()) {
          char buf[160];
          std::snprintf(buf, sizeof buf, "eval: %s PSNR %.2f dB, SSIM %.4f (%zu %s frames, %.1f s)",
                        rep.variants.back().name.c_str(), rep.variants.back().psnr, rep.variants.back().ssim,
                        rep.frame_names.size(), sp.c_str(), rep.eval_seconds);
          log(buf);
        }
      } else {
        log("eval: done before (" + run.report_json() + ")");
      }
      ojson report;
      if (read_json_object(run.report_json(), report)) done["report"] = fs::absolute(run.report_json()).lexically_normal().string();
      // ---- pack ----
      if (!fs::exists(p.avatar())) {
        enter("pack");
        PackOptions po;
        for (const auto& [k, v] : s.pack) {
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
        const PackedSizes ps = pack_run(run.dir, s.model, p.avatar(), po);
        log("pack: " + p.avatar() + ": " + std::to_string(ps.total) + " bytes, " + std::to_string(ps.num_gaussians) +
            " Gaussians");
      } else {
        log("pack: done before (" + p.avatar() + ")");
      }
      enter("check");
      const UnpackedAvatar back = read_avatar_file(p.avatar());
      done["gaussians"] = back.avatar.gaussians.size();
      done["avatar_bytes"] = fs::file_size(p.avatar());
      if (read_json_object(run.report_json(), report) && report.contains("variants") && report["variants"].is_array() &&
          !report["variants"].empty()) {
        const ojson& v = report["variants"].back();
        if (v.contains("psnr")) done["psnr"] = v["psnr"];
      }
    } catch (const std::exception& e) {
      failure.stage = stage;
      failure.error = e.what();
      const Error* he = dynamic_cast<const Error*>(&e);
      // haha::Error is the project's bad-input error (one line naming the file). Interrupts,
      // out of memory, file-system errors and failures after training started are retryable.
      failure.bad_input = he && !interrupted() && !(stage == "train" && train_started);
      if (dynamic_cast<const std::bad_alloc*>(&e)) failure.error = "out of memory (std::bad_alloc)";
    }
    heartbeat_progress = nullptr;
  }  // running.json removed
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::error_code ec;
  if (failure.stage.empty()) {
    double total = wall;
    if (had_failed) total += prev.value("wall_seconds", 0.0);
    ojson d;
    d["id"] = s.id;
    d["index"] = s.index;
    d["fingerprint"] = s.fingerprint();
    d["line"] = line_text;
    d["finished"] = utc_now();
    d["host"] = host_name();
    d["job"] = job;
    d["attempts"] = attempts;
    d["wall_seconds"] = total;
    d["last_attempt_seconds"] = wall;
    d["avatar"] = fs::absolute(p.avatar()).lexically_normal().string();
    for (auto it = done.begin(); it != done.end(); ++it) d[it.key()] = it.value();
    try {
      write_text_file(p.done(), d.dump(2) + "\n");
    } catch (const std::exception& e) {
      failure.stage = "done";
      failure.error = e.what();
    }
    if (failure.stage.empty()) {
      fs::remove(p.failed(), ec);
      char buf[96];
      std::snprintf(buf, sizeof buf, " (attempt %d, %.1f s)", attempts, wall);
      log(std::string("done: ") + p.avatar() + buf);
      res.message = s.id + ": done" + buf;
      return res;
    }
  }
  ojson f;
  f["id"] = s.id;
  f["index"] = s.index;
  f["kind"] = failure.bad_input ? "bad_input" : "retryable";
  f["stage"] = failure.stage;
  f["error"] = failure.error;
  f["exit_code"] = failure.bad_input ? int(kBatchBadInput) : int(kBatchRetryable);
  f["attempts"] = attempts;
  f["fingerprint"] = s.fingerprint();
  f["line"] = line_text;
  f["time"] = utc_now();
  f["host"] = host_name();
  f["job"] = job;
  f["wall_seconds"] = wall + (had_failed ? prev.value("wall_seconds", 0.0) : 0.0);
  f["hint"] = failure.bad_input ? "fix the input or the manifest line; the subject is not retried with the same line"
                                : "run the same index again: it resumes";
  try {
    write_text_file(p.failed(), f.dump(2) + "\n");
  } catch (const std::exception&) {
  }
  log(std::string(failure.bad_input ? "bad input" : "failed (retryable)") + " in " + failure.stage + ": " + failure.error);
  res.exit_code = failure.bad_input ? kBatchBadInput : kBatchRetryable;
  res.message = s.id + ": " + (failure.bad_input ? "bad input" : "retryable failure") + " in " + failure.stage + ": " +
                failure.error;
  return res;
}

}  // namespace haha
