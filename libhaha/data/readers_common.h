// Helpers shared by the dataset readers (readers_*.cpp); not a public API.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "data/readers.h"
#include "io/image.h"
#include "io/npy.h"
#include "core/camera.h"

namespace haha::readers {

// Files DIR/<prefix><number><suffix> with exactly `digits` digits (0 = any count),
// by number. Throws naming DIR when it is no directory.
std::map<int, std::string> list_numbered(const std::string& dir, const std::string& prefix, int digits,
                                         const std::string& suffix);

// "DIR/<prefix><number zero-padded to digits><suffix>", for naming missing files.
std::string numbered_name(const std::string& dir, const std::string& prefix, int number, int digits,
                          const std::string& suffix);

// Camera from an OpenCV intrinsic matrix (pixel centres at integers) and a 4x4 (or 3x4)
// world-to-camera matrix, both row-major. Validates (finite, fx, fy > 0, rotation).
Camera camera_from_opencv(const double* K, const double* world_to_camera, int width, int height,
                          const std::string& where);

// Crop then resize, applied identically to cameras and images.
struct PixelTransform {
  int src_w = 0, src_h = 0;
  int x0 = 0, y0 = 0, crop_w = 0, crop_h = 0;
  int out_w = 0, out_h = 0;
  static PixelTransform make(int src_w, int src_h, bool square_crop, int max_side);
  Camera apply(Camera cam) const;          // cam is src_w x src_h
  Image apply(const Image& img) const;     // img is src_w x src_h
};

// Mask from a .npy file: (H, W) or (H, W, 1) of bool, uint8, int or float. Integer masks
// with values above 1 are 0..255; floats are clamped to [0, 1].
Image read_mask_npy(const std::string& path);

// A mask image file (.png etc.: first channel) or .npy.
Image read_mask_file(const std::string& path);

// RGB from an image file (grey expanded, alpha dropped).
Image read_rgb(const std::string& path);

// Frame numbers kept after `every` and `max_frames` (ConvertOptions).
std::vector<int> subsample(const std::vector<int>& frames, int every, int max_frames);

// Text file's first word (gender.txt), empty when absent.
std::string read_first_word(const std::string& path);

}  // namespace haha::readers
