// .glb -> Avatar (format/spec.md). Everything is validated: a truncated or corrupt file,
// a checksum mismatch, a wrong extension version, a Draco stream that does not decode, a
// face index out of range or a NaN gives one haha::Error "<file>: <problem>"; no input
// makes the reader crash.
//
// The returned Avatar's body is the subject's rest shape with betas and expression baked
// into v_template (num_shape = num_expr = 0, no shapedirs): repose it with pose and
// translation only. avatar.betas / avatar.expression hold the trained values for reference.
// Body fields the file does not carry (hand PCA, landmarks) are empty; posedirs are
// present only if the file embeds pose correctives. In the lossy default the UV map is
// one UV per glTF vertex (vt) with ft = the glTF faces (same corner values as packed), the
// faces in the order the Gaussians name them (canonical in version-3 lossy files).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "format/animation.h"
#include "format/avatar_pack.h"

namespace haha {

struct UnpackOptions {
  // Check the CRC-32 of every Draco stream, image and array before decoding it. Off only
  // for fuzzing the decoders themselves.
  bool verify_checksums = true;
  // Files with importance tiers (haha pack --lod): read only the tiers whose running
  // count stays within this (the first tier always); 0 = every Gaussian.
  int max_gaussians = 0;
};

// What `haha info` shows.
struct AvatarFileInfo {
  int version = 0;
  PackedSizes sizes;  // bytes per part, counts
  int body_vertex_count = 0;
  // body.garment: the garment's part of the mesh (from these vertex / face indices on) and
  // the Gaussians bound to its faces; -1 when the file has none.
  int garment_first_vertex = -1, garment_first_face = -1, garment_gaussians = -1;
  int joint_regressor_nonzeros = 0;
  std::map<std::string, int> gaussian_bits;  // 0 = raw float32
  std::map<std::string, int> mesh_bits;
  std::string scale_encoding;                // "log" or "linear"
  std::string rotation_encoding;             // "smallest3" or "wxyz"
  std::string gaussian_order = "original";   // "face": sorted by face index (lossy packs)
  std::string gaussian_face_order = "file";  // "canonical": faces named independently of the file's order
  std::string texture_mime;
  int texture_width = 0, texture_height = 0;
  bool texture_exact = false;                // lossless float copy present
  std::string pose_correctives;              // "", "int16", "float32" or "sparse_lowrank" (embedded)
  int pose_corrective_blocks = 0;            // sparse_lowrank: kept (joint, vertex) blocks,
  int pose_corrective_rank = 0;              // mixing rows per joint,
  int pose_corrective_bits = 0;              // coefficient bits (0 = float32)
  bool trained_with_pose_correctives = false;  // the trainer applied them (loaders need the
                                               // body model's posedirs if not embedded)
  uint32_t topology_crc32 = 0;               // CRC-32 of the faces (int32, little-endian)
  bool splats = false;                       // KHR_gaussian_splatting primitive present
  std::vector<int> lod_counts;               // Gaussians per importance tier (empty: no tiers)
  std::vector<double> lod_psnr;              // PSNR of tiers 0..t vs all, as packed (inf: last)
  std::vector<std::string> extensions_used, extensions_required;
};

struct UnpackedAvatar {
  Avatar avatar;
  AvatarFileInfo info;
  std::vector<uint8_t> texture_image;  // the encoded image as stored (png/jpeg/webp)
  std::vector<AvatarAnimation> animations;  // the file's glTF animations (format/animation.h)
};

UnpackedAvatar unpack_avatar(const uint8_t* data, size_t size, const std::string& where,
                             const UnpackOptions& options = {});
UnpackedAvatar read_avatar_file(const std::string& path, const UnpackOptions& options = {});
inline Avatar read_avatar_glb(const std::string& path) { return read_avatar_file(path).avatar; }

// File extension of a texture mime type ("png", "jpg", "webp").
std::string texture_file_extension(const std::string& mime);

}  // namespace haha
