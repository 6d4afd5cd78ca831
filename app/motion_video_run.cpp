#include "app/motion_video_run.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "app/keypoint_tool.h"
#include "app/motion_video_truth.h"
#include "core/error.h"

namespace haha {

namespace {

namespace fs = std::filesystem;

// Removes the work folder however the run ends.
struct WorkDir {
  fs::path path;
  ~WorkDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void print_truth(const char* what, const MotionTruthErrors& e) {
  std::printf("motion: %s: body joints %.1f mm (root-aligned), acceleration error %.2f m/s^2, foot sliding %.2f cm per contact (%d contacts)\n",
              what, e.joint_mm, e.accel_error, e.slide_cm, e.contacts);
}

}  // namespace

void run_motion_from_video(const MotionVideoOptions& o, const BodyModel& body, const SmplxFitter& fit) {
  if (o.out.empty()) fail("--out", "missing");
  const auto t0 = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (!o.fit.progress) return;
    std::printf("motion: %s (%.1f s)\n", s.c_str(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::fflush(stdout);
  };
  FitVideoRunOptions fo = o.fit;
  fo.out = o.out;
  validate_fit_video_options(fo);
  // Cheap checks first, before anything long runs.
  check_input(fo.input);
  check_keypoint_tool(find_keypoint_tool(fo.keypoint_tool));
  FitVideoTruth truth;
  if (!o.truth.empty()) truth = read_fit_video_truth(o.truth, body);
  const WorkDir work{o.out + ".motion-work-" + std::to_string(::getpid())};
  std::error_code ec;
  fs::remove_all(work.path, ec);
  fs::create_directories(work.path);

  const FitVideoFits fits = fit_video_poses(fo, fit, work.path.string(), say);
  if (!o.truth.empty()) check_truth_frames(truth, fits.in.decoded);
  const double fps = fits.in.fps / fits.range.step;
  const int n = int(fits.in.paths.size());
  MotionFromFitReport rep;
  const Motion m = motion_from_fit(fits.result, n, fps, body, body, o.motion, &rep);
  char line[256];
  std::snprintf(line, sizeof line, "[4/4] %d frames at %.4g fps (%d bridged, %d cut at the ends), %d foot contacts held, scale %.3f",
                rep.frames, fps, rep.bridged, rep.cut, rep.contacts, rep.scale);
  say(line);
  write_motion_npz(m, o.out);
  std::printf("%s: %d frames at %.4g fps\n", o.out.c_str(), rep.frames, fps);
  if (o.truth.empty()) return;
  std::vector<int> idx;
  for (int t = 0; t < rep.frames; ++t) idx.push_back(fits.in.source_index[size_t(fits.result.kept.front() + t)]);
  MotionFromFitOptions raw = o.motion;  // the per-frame fit, only turned and scaled
  raw.filter.min_cutoff_hz = 1e9;
  raw.filter.beta = 0;
  raw.lock_feet = false;
  const Motion r = motion_from_fit(fits.result, n, fps, body, body, raw);
  const MotionFromFitOptions& mo = o.motion;
  print_truth("raw fit", motion_truth_errors(r, idx, truth, body, mo.contact_speed, mo.contact_height, mo.min_contact_frames));
  print_truth("motion", motion_truth_errors(m, idx, truth, body, mo.contact_speed, mo.contact_height, mo.min_contact_frames));
}

}  // namespace haha
