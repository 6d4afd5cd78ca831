// In-memory encoding/decoding of the avatar texture (PNG, JPEG, WebP through
// OpenImageIO's IOProxy; nothing touches the disk). Internal to haha_format.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "body/avatar.h"

namespace haha {

enum class TextureCodec { png, jpg, webp };

const char* texture_mime(TextureCodec c);       // "image/png", "image/jpeg", "image/webp"
const char* texture_extension(TextureCodec c);  // "png", "jpg", "webp"
TextureCodec texture_codec_from_name(const std::string& name);  // png|jpg|jpeg|webp, else Error

// 8-bit sRGB-as-stored encoding of tex.rgb (values clamped to [0, 1], rounded).
// quality: 1..100 for jpg/webp (ignored for png). Throws haha::Error if the codec is
// unavailable in this OpenImageIO build.
std::vector<uint8_t> encode_texture(const Texture& tex, TextureCodec codec, int quality);

// Decodes an RGB(A) image to a Texture (values / 255; alpha dropped). `where` names the
// file in errors.
Texture decode_texture(const uint8_t* data, size_t size, const std::string& mime, const std::string& where);

// Area-weighted resample to width x height (box filter when shrinking, bilinear with
// pixel centres at +0.5 when enlarging).
Texture resize_texture(const Texture& tex, int width, int height);

}  // namespace haha
