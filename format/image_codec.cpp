#include "format/image_codec.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace haha {

const char* texture_mime(TextureCodec c) {
  switch (c) {
    case TextureCodec::png: return "image/png";
    case TextureCodec::jpg: return "image/jpeg";
    case TextureCodec::webp: return "image/webp";
  }
  return "";
}

const char* texture_extension(TextureCodec c) {
  switch (c) {
    case TextureCodec::png: return "png";
    case TextureCodec::jpg: return "jpg";
    case TextureCodec::webp: return "webp";
  }
  return "";
}

TextureCodec texture_codec_from_name(const std::string& name) {
  if (name == "png") return TextureCodec::png;
  if (name == "jpg" || name == "jpeg") return TextureCodec::jpg;
  if (name == "webp") return TextureCodec::webp;
  fail("--texture", "unknown texture format '" + name + "' (use png, jpg or webp)");
}

std::vector<uint8_t> encode_texture(const Texture& tex, TextureCodec codec, int quality) {
  const std::string where = std::string("texture encoder (") + texture_extension(codec) + ")";
  if (tex.width <= 0 || tex.height <= 0 || tex.rgb.size() != size_t(tex.width) * tex.height * 3) {
    fail(where, "texture is empty or its size does not match width x height x 3");
  }
  std::vector<uint8_t> px(tex.rgb.size());
  for (size_t i = 0; i < px.size(); ++i) {
    const float v = tex.rgb[i];
    px[i] = uint8_t(std::lround(std::clamp(std::isfinite(v) ? v : 0.0f, 0.0f, 1.0f) * 255.0f));
  }
  const std::string name = std::string("texture.") + texture_extension(codec);
  auto out = OIIO::ImageOutput::create(name);
  if (!out) fail(where, "this OpenImageIO build cannot write " + std::string(texture_extension(codec)) + " images");
  if (!out->supports("ioproxy")) fail(where, "this OpenImageIO build cannot write " + std::string(texture_extension(codec)) + " to memory");
  std::vector<unsigned char> buf;
  OIIO::Filesystem::IOVecOutput proxy(buf);
  OIIO::ImageSpec spec(tex.width, tex.height, 3, OIIO::TypeDesc::UINT8);
  const int q = std::clamp(quality, 1, 100);
  if (codec == TextureCodec::jpg) {
    spec.attribute("compression", "jpeg:" + std::to_string(q));
    spec.attribute("jpeg:subsampling", "4:4:4");  // chroma subsampling blurs texture seams
  } else if (codec == TextureCodec::webp) {
    spec.attribute("compression", "webp:" + std::to_string(q));
  }
  out->set_ioproxy(&proxy);
  if (!out->open(name, spec) || !out->write_image(OIIO::TypeDesc::UINT8, px.data()) || !out->close()) {
    fail(where, "encoding failed: " + out->geterror());
  }
  return std::vector<uint8_t>(buf.begin(), buf.end());
}

Texture decode_texture(const uint8_t* data, size_t size, const std::string& mime, const std::string& where) {
  std::string ext;
  if (mime == "image/png") ext = "png";
  else if (mime == "image/jpeg") ext = "jpg";
  else if (mime == "image/webp") ext = "webp";
  else fail(where, "texture image: unsupported mimeType '" + mime + "'");
  OIIO::Filesystem::IOMemReader proxy(const_cast<uint8_t*>(data), size);
  OIIO::ImageSpec config;
  void* ptr = &proxy;
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &ptr);
  auto in = OIIO::ImageInput::open("texture." + ext, &config);
  if (!in) fail(where, "texture image (" + ext + ") does not decode: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.width > 16384 || spec.height > 16384 || spec.nchannels < 3) {
    fail(where, "texture image: unsupported size or channel count (" + std::to_string(spec.width) + " x " +
                    std::to_string(spec.height) + " x " + std::to_string(spec.nchannels) + ")");
  }
  Texture t;
  t.width = spec.width;
  t.height = spec.height;
  std::vector<uint8_t> px(size_t(t.width) * t.height * 3);
  if (!in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data())) {
    fail(where, "texture image (" + ext + ") does not decode: " + in->geterror());
  }
  t.rgb.resize(px.size());
  for (size_t i = 0; i < px.size(); ++i) t.rgb[i] = float(px[i]) / 255.0f;
  return t;
}

namespace {

// Resamples `n_in` samples (stride `stride_in`) to `n_out` along one axis, for each of
// `count` lines with 3 channels. Box filter when shrinking, bilinear when enlarging.
void resample_axis(const std::vector<float>& in, std::vector<float>& out, int n_in, int n_out, int lines,
                   bool along_rows, int width_in_other) {
  // Index helpers: a line is a row (along x) or a column (along y).
  auto at = [&](int line, int i, int n, int c) -> size_t {
    return along_rows ? (size_t(line) * n + i) * 3 + c : (size_t(i) * width_in_other + line) * 3 + c;
  };
  const double scale = double(n_in) / n_out;
  for (int line = 0; line < lines; ++line) {
    for (int o = 0; o < n_out; ++o) {
      double acc[3] = {0, 0, 0};
      if (scale > 1.0) {
        const double x0 = o * scale, x1 = (o + 1) * scale;
        double wsum = 0;
        for (int i = int(std::floor(x0)); i < int(std::ceil(x1)) && i < n_in; ++i) {
          const double w = std::min(x1, double(i + 1)) - std::max(x0, double(i));
          if (w <= 0) continue;
          for (int c = 0; c < 3; ++c) acc[c] += w * in[at(line, i, n_in, c)];
          wsum += w;
        }
        for (double& a : acc) a /= wsum;
      } else {
        const double x = (o + 0.5) * scale - 0.5;
        const int i0 = std::clamp(int(std::floor(x)), 0, n_in - 1);
        const int i1 = std::min(i0 + 1, n_in - 1);
        const double t = std::clamp(x - std::floor(x), 0.0, 1.0) * (x >= 0 ? 1 : 0);
        for (int c = 0; c < 3; ++c) acc[c] = (1 - t) * in[at(line, i0, n_in, c)] + t * in[at(line, i1, n_in, c)];
      }
      for (int c = 0; c < 3; ++c) out[at(line, o, n_out, c)] = float(acc[c]);
    }
  }
}

}  // namespace

Texture resize_texture(const Texture& tex, int width, int height) {
  if (width <= 0 || height <= 0) fail("--texture-size", "texture size must be positive");
  if (width == tex.width && height == tex.height) return tex;
  // Rows first (W_in -> W_out for each of H_in rows), then columns.
  std::vector<float> tmp(size_t(width) * tex.height * 3);
  resample_axis(tex.rgb, tmp, tex.width, width, tex.height, true, 0);
  Texture out;
  out.width = width;
  out.height = height;
  out.rgb.resize(size_t(width) * height * 3);
  resample_axis(tmp, out.rgb, tex.height, height, width, false, width);
  return out;
}

}  // namespace haha
