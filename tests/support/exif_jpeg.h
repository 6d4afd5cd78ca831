// A small grey JPEG with an EXIF 35 mm-equivalent focal length, as phones write it: the
// input of the focal tests of `haha fit-video`.
#pragma once

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace haha::test {

// A w x h JPEG at `path`, with EXIF FocalLengthIn35mmFilm when mm > 0.
inline void write_exif_jpeg(const std::string& path, int w, int h, int mm) {
  auto out = OIIO::ImageOutput::create(path);
  OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
  if (mm > 0) spec.attribute("Exif:FocalLengthIn35mmFilm", mm);
  std::vector<unsigned char> px(size_t(w) * h * 3, 128);
  EXPECT_TRUE(out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close());
}

}  // namespace haha::test
