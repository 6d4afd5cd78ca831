// Background-aware matting for videos from a static camera (`haha fit-video`). A person
// mask from a segmentation model is soft at the edge, and there the frame's pixel is
// I = a F + (1 - a) B: composited as mask x image, the backdrop's colour B leaks into the
// avatar's edge (a light fringe in front of a white wall). With the clean background plate
// B known, a and the premultiplied colour a F follow from I:
//   1. the plate: per pixel the median over the frames whose dilated person mask leaves it
//      uncovered; pixels never uncovered are holes. A person who turns on the spot never
//      uncovers the pixels at their own outline, so holes near seen pixels are filled from
//      the nearest seen pixel where the background around it is smooth (a plain wall);
//      elsewhere in the holes the tool's mask stays;
//   2. whether the camera is static: the median |I - B| over each frame's uncovered pixels
//      (the residual) is near the codec's noise for a tripod, far above it when the camera
//      moves or the exposure changes (then the plate means nothing and the tool's masks stay);
//   3. per frame, in a band around the tool's mask edge: F from the nearest confident
//      foreground pixel, a = clamp((I - B).(F - B) / |F - B|^2, 0, 1), blended towards the
//      tool's mask where |F - B| is too small to tell; a F = I - (1 - a) B clamped to [0, a].
//      Inside the band's inner side a = 1, outside its outer side a = 0.
// Pure functions on core/image.h's Image; frames are kept as 8-bit copies (about 4 bytes
// per pixel and frame) while the plate is made.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/image.h"

namespace haha {

struct MattingOptions {
  int band_px = 0;                 // half-width of the band around the mask edge; 0: matting_band_px()
  int plate_dilate_px = 0;         // person mask dilation when the plate samples a frame; 0: 2 x band
  float cover_threshold = 0.02f;   // mask value from which a pixel is the person's (for the plate)
  float min_contrast = 0.12f;      // |F - B| (RGB distance, [0, 1] units) below which the tool's mask decides
  double static_threshold = 0.02;  // residual ([0, 1] units) above which the camera counts as moving
  int fill_px = 0;                 // holes this far from a seen pixel are filled; 0: 10 x band
  float fill_smooth = 0.03f;       // ... when the seen pixels within 2 bands of the source pixel
                                   // differ from it by at most this (per channel, [0, 1])
};

// The default band: 3 px up to 600 px frames, then 1/200 of the longer side (6 px at 1280).
int matting_band_px(int width, int height);

struct BackgroundPlate {
  int width = 0, height = 0;
  Image rgb;                   // (H, W, 3) median background (filled holes: their fill); 0 in holes
  std::vector<uint8_t> known;  // per pixel: 0 hole, 1 seen in some frame, 2 a filled hole
  int frames = 0;              // frames it was made of
  double hole_share = 0;       // share of the pixels never uncovered (filled or not)
  double filled_share = 0;     // share of the pixels filled (part of the holes)
  std::vector<double> frame_residual;  // per frame: median over its uncovered, known pixels of
                                       // the mean |I - B| over RGB ([0, 1]); NaN: no such pixel
  double residual = NAN;       // median of the finite frame residuals (NaN: none)
  bool camera_static(const MattingOptions& opt = {}) const {
    return std::isfinite(residual) && residual <= opt.static_threshold;
  }
};

// Collects the frames (8-bit) and makes the plate from them.
class BackgroundPlateBuilder {
 public:
  BackgroundPlateBuilder(int width, int height, const MattingOptions& opt = {});
  // `rgb` (H, W, 3) in [0, 1], `mask` the person's (H, W, 1) (empty: nobody in the frame).
  // Throws haha::Error "background plate: ..." on a size mismatch.
  void add(const Image& rgb, const Image& mask);
  void reserve(int frames);  // room for this many frames at once (no regrowth while adding)
  int frames() const { return n_; }
  BackgroundPlate build() const;

 private:
  int w_ = 0, h_ = 0, dilate_ = 0;
  MattingOptions opt_;
  int n_ = 0;
  std::vector<uint8_t> rgb_;    // n x H x W x 3
  std::vector<uint8_t> cover_;  // n x H x W: 1 = the dilated person mask covers it
};

struct Matte {
  Image alpha;               // (H, W, 1)
  Image premultiplied;       // (H, W, 3) a F on black
  double band_share = 0;     // share of the frame's pixels in the band
  double band_known = 0;     // share of the band's pixels where the plate was known (seen or filled)
  double band_filled = 0;    // share of the band's pixels where it was a filled hole
};

// The frame's alpha and premultiplied colour against `plate` (same size; an empty plate
// gives the tool's mask and mask x rgb). Throws haha::Error "matting: ..." on a size mismatch.
Matte refine_matte(const Image& rgb, const Image& mask, const BackgroundPlate& plate, const MattingOptions& opt = {});

}  // namespace haha
