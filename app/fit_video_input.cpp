#include "app/fit_video_input.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "core/subprocess.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "core/text.h"
#include "io/image.h"

namespace haha {

namespace fs = std::filesystem;

namespace {

constexpr const char* kInstallFfmpeg = "apt-get install ffmpeg";

bool parse_count(const std::string& s, int* v) {
  if (s.empty() || s.size() > 9 || !std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit((unsigned char)c); }))
    return false;
  *v = std::atoi(s.c_str());
  return true;
}

bool is_image_name(const fs::path& p) {
  const std::string e = ascii_lower(p.extension().string());
  return e == ".png" || e == ".jpg" || e == ".jpeg";
}

// Images of a folder in name order.
std::vector<fs::path> list_images(const std::string& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file(ec) && is_image_name(e.path())) out.push_back(e.path());
  if (ec) fail(dir, "cannot list the folder: " + ec.message());
  std::sort(out.begin(), out.end());
  return out;
}

// Every file has the size of the first (headers only).
void check_same_size(const std::vector<fs::path>& files, int* width, int* height) {
  const ImageInfo first = read_image_info(files.front().string());
  for (const fs::path& f : files) {
    const ImageInfo info = &f == &files.front() ? first : read_image_info(f.string());
    if (info.width != first.width || info.height != first.height)
      fail(f.string(), "image is " + std::to_string(info.width) + "x" + std::to_string(info.height) + " but " +
                           files.front().filename().string() + " is " + std::to_string(first.width) + "x" +
                           std::to_string(first.height) + ": all frames must have one size");
  }
  *width = first.width;
  *height = first.height;
}

struct VideoInfo {
  int width = 0, height = 0;
  double fps = 0;  // 0: unknown
};

double parse_rate(const std::string& r) {  // "30000/1001", "25/1", "0/0"
  const size_t slash = r.find('/');
  const double num = std::atof(r.substr(0, slash).c_str());
  const double den = slash == std::string::npos ? 1.0 : std::atof(r.substr(slash + 1).c_str());
  return den > 0 && num > 0 && std::isfinite(num / den) ? num / den : 0.0;
}

VideoInfo probe_video(const std::string& input) {
  if (!program_on_path("ffmpeg") || !program_on_path("ffprobe"))
    fail(input, std::string("decoding a video needs ffmpeg, which is not installed (") + kInstallFfmpeg + ")");
  std::string out;
  const int st = run_capture("ffprobe -v error -select_streams v:0 -show_entries stream=width,height,avg_frame_rate,"
                             "r_frame_rate -of default=noprint_wrappers=1 " + shell_quoted(input), out);
  VideoInfo v;
  double avg = 0, r = 0;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    const size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string k = line.substr(0, eq), val = line.substr(eq + 1);
    if (k == "width") v.width = std::atoi(val.c_str());
    if (k == "height") v.height = std::atoi(val.c_str());
    if (k == "avg_frame_rate") avg = parse_rate(val);
    if (k == "r_frame_rate") r = parse_rate(val);
  }
  if (st != 0 || v.width <= 0 || v.height <= 0)
    fail(input, "not a video ffmpeg can read (" + (st != 0 ? last_line(out) : std::string("no video stream")) + ")");
  v.fps = avg > 0 ? avg : r;
  return v;
}

}  // namespace

FrameRange parse_frame_range(const std::string& text) {
  FrameRange r;
  std::vector<std::string> parts;
  std::string cur;
  for (char c : text) {
    if (c == ':') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  auto bad = [&](const std::string& why) { fail("--frames", "'" + text + "': " + why + " (expected A:B:S, e.g. 0:300:2)"); };
  if (parts.size() > 3) bad("too many parts");
  if (!parts[0].empty() && !parse_count(parts[0], &r.first)) bad("first frame is not a non-negative integer");
  if (parts.size() > 1 && !parts[1].empty()) {
    if (!parse_count(parts[1], &r.last)) bad("last frame is not a non-negative integer");
    if (r.last <= r.first) bad("the last frame (exclusive) must be after the first");
  }
  if (parts.size() > 2 && !parts[2].empty()) {
    if (!parse_count(parts[2], &r.step) || r.step < 1) bad("step must be an integer >= 1");
  }
  return r;
}

std::vector<int> select_frames(const FrameRange& r, int n) {
  std::vector<int> out;
  const int end = r.last < 0 ? n : std::min(r.last, n);
  for (int i = r.first; i < end; i += r.step) out.push_back(i);
  return out;
}

void check_input(const std::string& input) {
  std::error_code ec;
  if (input.empty()) fail("INPUT", "give a video file or a folder of images");
  if (!fs::exists(input, ec)) fail(input, "no such file or folder");
  if (fs::is_directory(input, ec)) {
    const std::vector<fs::path> files = list_images(input);
    if (files.empty()) fail(input, "the folder holds no .png or .jpg images");
    int w = 0, h = 0;
    check_same_size(files, &w, &h);
  } else {
    probe_video(input);
  }
}

InputFrames prepare_input_frames(const std::string& input, const std::string& work_dir, double fps,
                                 const FrameRange& range, bool progress) {
  InputFrames f;
  std::error_code ec;
  const fs::path frames_dir = fs::path(work_dir) / "frames";
  fs::remove_all(frames_dir, ec);
  ensure_directory(frames_dir.string());
  auto frame_path = [&](size_t k) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", k);
    return (frames_dir / name).string();
  };
  f.is_video = !fs::is_directory(input, ec);
  if (f.is_video) {
    const VideoInfo v = probe_video(input);
    f.fps = fps > 0 ? fps : (v.fps > 0 ? v.fps : 30.0);
    const fs::path decoded = fs::path(work_dir) / "decoded";
    fs::remove_all(decoded, ec);
    ensure_directory(decoded.string());
    char rate[64] = "";
    if (fps > 0) std::snprintf(rate, sizeof rate, " -vf fps=%.9g", fps);
    if (progress) std::printf("  decoding %s with ffmpeg%s\n", input.c_str(), rate);
    // passthrough: every decoded frame once (no duplicates or drops for variable frame rates).
    // -progress on stdout: "frame=N" lines for our progress; errors to a log for the message.
    const std::string log = (fs::path(work_dir) / "ffmpeg.log").string();
    const std::string cmd = "ffmpeg -nostdin -v error -nostats -progress pipe:1 -i " + shell_quoted(input) +
                            (fps > 0 ? std::string(rate) : " -fps_mode passthrough") + " -pix_fmt rgb24 -start_number 0 " +
                            shell_quoted((decoded / "%06d.png").string()) + " 2> " + shell_quoted(log);
    std::fflush(stdout);
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) fail(input, "cannot start ffmpeg");
    char line[256];
    int last_said = 0;
    while (std::fgets(line, sizeof line, p)) {
      const int frame = std::strncmp(line, "frame=", 6) == 0 ? std::atoi(line + 6) : 0;
      if (progress && frame >= last_said + 100) {
        std::printf("  decoded %d frames\n", frame);
        std::fflush(stdout);
        last_said = frame;
      }
    }
    const int status = pclose(p);  // ffmpeg got the terminal's Ctrl-C itself
    check_interrupted();
    if (status != 0) {
      std::string text;
      try {
        text = read_text_file(log);
      } catch (const Error&) {
      }
      fail(input, "ffmpeg cannot decode it (" + last_line(text) + ")");
    }
    const std::vector<fs::path> all = list_images(decoded.string());
    f.decoded = int(all.size());
    if (all.empty()) fail(input, "no frames decoded");
    for (int i : select_frames(range, f.decoded)) {
      const std::string dst = frame_path(f.paths.size());
      fs::rename(all[size_t(i)], dst, ec);
      if (ec) fail(dst, "cannot move the decoded frame: " + ec.message());
      f.source_index.push_back(i);
      f.names.push_back("frame " + std::to_string(i));
      f.paths.push_back(dst);
    }
    fs::remove_all(decoded, ec);
  } else {
    f.fps = fps > 0 ? fps : 30.0;
    const std::vector<fs::path> all = list_images(input);
    f.decoded = int(all.size());
    if (all.empty()) fail(input, "the folder holds no .png or .jpg images");
    const std::vector<int> sel = select_frames(range, f.decoded);
    std::vector<fs::path> picked;
    for (int i : sel) picked.push_back(all[size_t(i)]);
    if (!picked.empty()) check_same_size(picked, &f.width, &f.height);  // before any copying
    // Re-encoded as RGB PNG: one format for the tool and the dataset, each file checked.
    for (size_t k = 0; k < sel.size(); ++k) {
      const fs::path& src = all[size_t(sel[k])];
      write_image(frame_path(k), to_rgb(read_image(src.string()), src.string()));
      f.source_index.push_back(sel[k]);
      f.names.push_back(src.filename().string());
      f.paths.push_back(frame_path(k));
      check_interrupted();
      if (progress && sel.size() >= 10 && (k + 1) % (sel.size() / 10) == 0)
        std::printf("  frames: %zu / %zu copied\n", k + 1, sel.size());
    }
  }
  if (f.paths.empty())
    fail("--frames", "selects no frame of the " + std::to_string(f.decoded) + (f.is_video ? " decoded" : " found"));
  if (f.is_video) {
    const std::vector<fs::path> sel_paths(f.paths.begin(), f.paths.end());
    check_same_size(sel_paths, &f.width, &f.height);
  }
  return f;
}

}  // namespace haha
