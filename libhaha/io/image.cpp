#include "io/image.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/text.h"

namespace haha {
namespace {

// OIIO messages may span lines; errors here are one line.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s.empty() ? "unknown error" : s;
}

constexpr int64_t kMaxSide = 65536;

// OpenEXR allocates from header fields while opening the file, before OpenImageIO hands
// us a spec (fuzzing found an attribute size that made it take 2 GB), so EXR headers are
// checked here first: every attribute must fit in the file, every dataWindow /
// displayWindow must be a box within kMaxSide. Layout: magic, version, then
// (name\0 type\0 int32 size, value) attributes up to an empty name.
void check_exr_header(const std::string& path) {
  std::error_code ec;
  const uint64_t file_size = std::filesystem::file_size(path, ec);
  if (ec) return;
  std::ifstream f(path, std::ios::binary);
  std::vector<char> h(65536);
  f.read(h.data(), std::streamsize(h.size()));
  h.resize(size_t(f.gcount()));
  if (h.size() < 8 || uint8_t(h[0]) != 0x76 || uint8_t(h[1]) != 0x2f || uint8_t(h[2]) != 0x31 || uint8_t(h[3]) != 0x01)
    return;  // not an EXR: its own reader decides
  size_t p = 8;
  auto cstr = [&](std::string& out) {
    const auto end = std::find(h.begin() + std::ptrdiff_t(std::min(p, h.size())), h.end(), '\0');
    if (end == h.end()) return false;
    out.assign(h.begin() + std::ptrdiff_t(p), end);
    p = size_t(end - h.begin()) + 1;
    return true;
  };
  std::string name, type;
  while (cstr(name) && !name.empty() && cstr(type)) {
    if (p + 4 > h.size()) return;
    int32_t size;
    std::memcpy(&size, &h[p], 4);
    p += 4;
    if (size < 0 || p + uint64_t(size) > file_size)
      fail(path, "corrupt EXR header: attribute '" + name + "' claims " + std::to_string(size) + " bytes, the file has " +
                     std::to_string(file_size));
    if (p + size_t(size) > h.size()) return;  // a header past 64 KiB: OpenEXR checks the rest
    if (type == "box2i" && size == 16 && (name == "dataWindow" || name == "displayWindow")) {
      int32_t b[4];
      std::memcpy(b, &h[p], 16);
      const int64_t w = int64_t(b[2]) - b[0] + 1, hgt = int64_t(b[3]) - b[1] + 1;
      if (w < 1 || hgt < 1 || w > kMaxSide || hgt > kMaxSide)
        fail(path, "image too large or unsupported: EXR " + name + " of " + std::to_string(w) + " x " +
                       std::to_string(hgt) + " pixels");
    }
    p += size_t(size);
  }
}

std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, "cannot read image: no such file");
  check_exr_header(path);
  // Alpha is data here (masks, RGBA frames): no (un)premultiplication on the way.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) fail(path, "cannot read image: " + one_line(OIIO::geterror()));
  const OIIO::ImageSpec& s = in->spec();
  if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0) fail(path, "cannot read image: empty image");
  // Decoded images are float: refuse sizes past 1 GiB of them before allocating (a tiny
  // compressed file can declare a huge, uniform image). Sides are bounded too: decoders
  // buffer whole chunks of scanlines (EXR DWAB: 256 lines of the declared width), and
  // volume images or more than 16 channels are nothing this project reads.
  if (s.width > kMaxSide || s.height > kMaxSide || s.depth != 1 || s.nchannels > 16)
    fail(path, "image too large or unsupported: " + std::to_string(s.width) + " x " + std::to_string(s.height) + " x " +
                   std::to_string(s.depth) + " pixels, " + std::to_string(s.nchannels) + " channels");
  if (int64_t(s.width) * s.height * s.nchannels > (int64_t(1) << 28))
    fail(path, "image too large: " + std::to_string(s.width) + " x " + std::to_string(s.height) + " x " +
                   std::to_string(s.nchannels) + " values exceed 1 GiB as float");
  return in;
}

std::string lower_extension(const std::string& path) {
  return ascii_lower(std::filesystem::path(path).extension().string());
}

}  // namespace

ImageInfo read_image_info(const std::string& path) {
  auto in = open_input(path);
  ImageInfo info;
  info.width = in->spec().width;
  info.height = in->spec().height;
  info.channels = in->spec().nchannels;
  info.format = in->format_name();
  info.focal_35mm = std::max(0, in->spec().get_int_attribute("Exif:FocalLengthIn35mmFilm", 0));
  in->close();
  return info;
}

Image read_image(const std::string& path) {
  auto in = open_input(path);
  const OIIO::ImageSpec& s = in->spec();
  Image img(s.width, s.height, s.nchannels);
  // Reading as FLOAT normalises integer types to [0, 1].
  if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeDesc::FLOAT, img.data.data()))
    fail(path, "cannot decode image: " + one_line(in->geterror()));
  in->close();
  return img;
}

Image read_depth(const std::string& path) {
  auto in = open_input(path);
  const OIIO::ImageSpec& s = in->spec();
  Image img(s.width, s.height, 1);
  const size_t n = size_t(s.width) * s.height;
  const OIIO::TypeDesc t = s.format;
  auto read_as = [&](OIIO::TypeDesc type, auto* buf) {
    if (!in->read_image(0, 0, 0, 1, type, buf)) fail(path, "cannot decode depth image: " + one_line(in->geterror()));
  };
  if (t.basetype == OIIO::TypeDesc::UINT8 || t.basetype == OIIO::TypeDesc::INT8 ||
      t.basetype == OIIO::TypeDesc::UINT16 || t.basetype == OIIO::TypeDesc::INT16) {
    // Read in the stored type (OIIO would rescale when converting), then widen.
    if (t.basetype == OIIO::TypeDesc::UINT16) {
      std::vector<uint16_t> raw16(n);
      read_as(OIIO::TypeDesc::UINT16, raw16.data());
      for (size_t i = 0; i < n; ++i) img.data[i] = float(raw16[i]);
    } else if (t.basetype == OIIO::TypeDesc::UINT8) {
      std::vector<uint8_t> raw8(n);
      read_as(OIIO::TypeDesc::UINT8, raw8.data());
      for (size_t i = 0; i < n; ++i) img.data[i] = float(raw8[i]);
    } else if (t.basetype == OIIO::TypeDesc::INT16) {
      std::vector<int16_t> r(n);
      read_as(OIIO::TypeDesc::INT16, r.data());
      for (size_t i = 0; i < n; ++i) img.data[i] = float(r[i]);
    } else {
      std::vector<int8_t> r(n);
      read_as(OIIO::TypeDesc::INT8, r.data());
      for (size_t i = 0; i < n; ++i) img.data[i] = float(r[i]);
    }
  } else if (t.basetype == OIIO::TypeDesc::UINT32 || t.basetype == OIIO::TypeDesc::INT32) {
    std::vector<uint32_t> r(n);
    read_as(t, r.data());
    for (size_t i = 0; i < n; ++i)
      img.data[i] = t.basetype == OIIO::TypeDesc::INT32 ? float(int32_t(r[i])) : float(r[i]);
  } else {
    read_as(OIIO::TypeDesc::FLOAT, img.data.data());
  }
  in->close();
  return img;
}

void write_image(const std::string& path, const Image& img, bool exr_full_float) {
  if (img.width <= 0 || img.height <= 0 || img.channels < 1 || img.channels > 4 ||
      img.data.size() != size_t(img.width) * img.height * img.channels)
    fail(path, "cannot write image: bad image size " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                   "x" + std::to_string(img.channels) + " with " + std::to_string(img.data.size()) + " values");
  for (size_t i = 0; i < img.data.size(); ++i)
    if (!std::isfinite(img.data[i]))
      fail(path, "cannot write image: non-finite value at pixel " + std::to_string(i / size_t(img.channels)));
  const std::string ext = lower_extension(path);
  OIIO::TypeDesc type;
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") {
    type = OIIO::TypeDesc::UINT8;
    if (ext != ".png" && img.channels != 1 && img.channels != 3)
      fail(path, "cannot write image: jpeg takes 1 or 3 channels, not " + std::to_string(img.channels));
  } else if (ext == ".exr") {
    type = exr_full_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::HALF;
  } else if (ext == ".tif" || ext == ".tiff") {
    type = OIIO::TypeDesc::FLOAT;
  } else {
    fail(path, "cannot write image: unknown extension '" + ext + "' (use .png, .jpg, .exr or .tiff)");
  }
  write_atomically(path, [&](const std::string& tmp) {
    // The plugin is chosen from the final name; the bytes go to the temporary file.
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, "cannot write image: " + one_line(OIIO::geterror()));
    OIIO::ImageSpec spec(img.width, img.height, img.channels, type);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (type == OIIO::TypeDesc::UINT8 && ext != ".png") spec.attribute("Compression", "jpeg:95");
    if (!out->open(tmp, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()) || !out->close())
      fail(path, "cannot write image: " + one_line(out->geterror()));
  });
}

}  // namespace haha
