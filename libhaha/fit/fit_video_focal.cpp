// The focal length of `haha fit-video` (fit/fit_video_focal.h).
#include "fit/fit_video_focal.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <sstream>

#include "core/subprocess.h"
#include "core/text.h"
#include "io/image.h"

namespace haha {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr const char* kAppleFocalKey = "com.apple.quicktime.camera.focal_length.35mm_equivalent";

std::string number(double v, int digits) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

}  // namespace

double focal_px_from_35mm(double mm, int width, int height) {
  return mm * std::hypot(double(width), double(height)) / kFullFrameDiagonalMm;
}

double focal_px_from_fov(double fov_deg, int width) { return 0.5 * width / std::tan(0.5 * fov_deg * kPi / 180.0); }

std::optional<double> parse_focal_35mm(const std::string& text) {
  std::string t = ascii_lower(text);
  while (!t.empty() && std::isspace((unsigned char)t.back())) t.pop_back();
  if (t.size() >= 2 && t.compare(t.size() - 2, 2, "mm") == 0) t.resize(t.size() - 2);
  while (!t.empty() && std::isspace((unsigned char)t.back())) t.pop_back();
  size_t b = 0;
  while (b < t.size() && std::isspace((unsigned char)t[b])) ++b;
  t = t.substr(b);
  if (t.empty() || t.size() > 32) return std::nullopt;
  for (char c : t)
    if (!std::isdigit((unsigned char)c) && c != '.') return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size() || !std::isfinite(v) || v < kFocal35mmMin || v > kFocal35mmMax) return std::nullopt;
  return v;
}

RecordedFocal video_recorded_focal(const std::string& video) {
  RecordedFocal r;
  if (!program_on_path("ffprobe")) return r;
  std::string out;
  // File-level and stream-level tags, one "TAG:key=value" per line.
  if (run_capture("ffprobe -v error -show_entries format_tags:stream_tags -of default=noprint_wrappers=1 " +
                      shell_quoted(video),
                  out) != 0)
    return r;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    const size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    std::string key = ascii_lower(line.substr(0, eq));
    if (key.compare(0, 4, "tag:") == 0) key = key.substr(4);
    if (key != kAppleFocalKey) continue;
    r.found = true;
    r.text = line.substr(eq + 1);
    r.where = std::string("the video's ") + kAppleFocalKey + " tag";
    return r;
  }
  return r;
}

RecordedFocal image_recorded_focal(const std::string& image) {
  RecordedFocal r;
  const ImageInfo info = read_image_info(image);
  if (info.focal_35mm > 0) {
    r.found = true;
    r.text = number(info.focal_35mm, 0);
    r.where = "EXIF FocalLengthIn35mmFilm of " + image;
  }
  return r;
}

FocalChoice choose_focal(double focal_px, double focal_35mm, double fov_deg, bool fov_given, const RecordedFocal& recorded,
                         int width, int height) {
  FocalChoice c;
  if (focal_px > 0) {
    c.focal_px = focal_px;
    c.source = "--focal " + number(focal_px, 1) + " px";
    return c;
  }
  if (focal_35mm > 0) {
    c.focal_px = focal_px_from_35mm(focal_35mm, width, height);
    c.source = "--focal-35mm " + number(focal_35mm, 1) + " mm";
    return c;
  }
  const std::string guess = "the --fov " + number(fov_deg, 1) + " deg " + (fov_given ? "given" : "guess");
  c.focal_px = focal_px_from_fov(fov_deg, width);
  c.source = guess;
  if (fov_given || !recorded.found) return c;
  if (const std::optional<double> mm = parse_focal_35mm(recorded.text)) {
    c.focal_px = focal_px_from_35mm(*mm, width, height);
    c.source = number(*mm, 1) + " mm (35 mm equivalent) from " + recorded.where;
  } else {
    c.source += " (" + recorded.where + " says '" + recorded.text.substr(0, 40) + "': not a focal length, ignored)";
  }
  return c;
}

}  // namespace haha
