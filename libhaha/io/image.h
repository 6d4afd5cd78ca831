// Image files through OpenImageIO (png, jpg, exr, tiff, anything else OIIO reads).
// Pixels are core/image.h's Image (float, row-major, top row first, channels interleaved;
// resampling and crops are there too). Values are the stored (display-encoded) values: no
// colour-space conversion happens on read or write.
#pragma once

#include <string>

#include "core/image.h"

namespace haha {

struct ImageInfo {
  int width = 0, height = 0, channels = 0;
  std::string format;  // OIIO's format name, e.g. "png", "tiff"
  double focal_35mm = 0;  // the camera's 35 mm-equivalent focal length from EXIF
                          // (FocalLengthIn35mmFilm), millimetres; 0: not recorded
};

// Opens the file and reads its header only. Throws haha::Error "path: cannot read image: ..."
ImageInfo read_image_info(const std::string& path);

// Reads all channels. Integer pixel types are normalised to [0, 1] (8-bit / 255, 16-bit /
// 65535); float and half pixels are kept as stored.
Image read_image(const std::string& path);

// Reads the first channel with integer types NOT normalised (a uint16 depth in millimetres
// stays in millimetres); float types as stored. For depth maps (X-Humans tiff).
Image read_depth(const std::string& path);

// Writes by extension: .png/.jpg/.jpeg 8-bit (values clamped to [0, 1], rounded; jpeg
// quality 95); .exr half-float (`exr_full_float`: float32); .tif/.tiff float32. 1, 2, 3 or 4
// channels (jpeg: 1 or 3). Non-finite values are an error naming the file. Atomic.
void write_image(const std::string& path, const Image& img, bool exr_full_float = false);

}  // namespace haha
