// The camera's focal length for `haha fit-video`. The fit cannot find it by itself (its
// keypoint error hardly changes with the focal; docs/fit-video.md), yet the true one is worth
// about 0.3 dB to the avatar, so it comes from, first to last:
//   --focal PX                 pixels;
//   --focal-35mm MM            the 35 mm-equivalent focal length of the lens (phone spec sheets
//                              give it, e.g. 26 mm for a main camera);
//   --fov DEG                  when given;
//   the input's own record     a video's com.apple.quicktime.camera.focal_length.35mm_equivalent
//                              tag (iPhones write it) where ffprobe shows it; an image folder's
//                              EXIF FocalLengthIn35mmFilm (of the first image);
//   the --fov default guess    (55 degrees across).
// A 35 mm-equivalent focal length is defined on the 36 x 24 mm frame's diagonal (43.27 mm):
// the frame's diagonal in pixels spans that many millimetres. A video mode that crops the
// sensor more than the photo mode (stabilisation) makes this a few percent short.
#pragma once

#include <optional>
#include <string>

namespace haha {

constexpr double kFullFrameDiagonalMm = 43.26661530556787;  // sqrt(36^2 + 24^2)
// 35 mm-equivalent focal lengths outside this range are not taken from metadata.
constexpr double kFocal35mmMin = 4, kFocal35mmMax = 2000;

// Pixels of a width x height frame.
double focal_px_from_35mm(double mm, int width, int height);
// Pixels of a horizontal field of view (degrees) across `width`.
double focal_px_from_fov(double fov_deg, int width);

// A metadata value: "26", "26.0", "50.00mm", "27 mm" -> millimetres; nullopt for anything
// else or outside [kFocal35mmMin, kFocal35mmMax].
std::optional<double> parse_focal_35mm(const std::string& text);

// What the input itself records, as the raw text and where it was found; `found` false when
// nothing is recorded (or ffprobe is missing).
struct RecordedFocal {
  bool found = false;
  std::string text;   // the value as recorded
  std::string where;  // "the video's <tag> tag", "EXIF FocalLengthIn35mmFilm of <image>"
};
RecordedFocal video_recorded_focal(const std::string& video);
RecordedFocal image_recorded_focal(const std::string& image);

struct FocalChoice {
  double focal_px = 0;
  std::string source;  // one line for the progress output and the report
};

// The order above. `focal_px` / `focal_35mm` 0 and `fov_given` false: not given.
FocalChoice choose_focal(double focal_px, double focal_35mm, double fov_deg, bool fov_given, const RecordedFocal& recorded,
                         int width, int height);

}  // namespace haha
