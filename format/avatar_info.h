// What `haha info` and `haha unpack` report about a packed avatar: per-part sizes,
// quantization, extensions, and the storage comparison (this file vs. the same
// Gaussians as a standard 3DGS .ply vs. the paper's float32 accounting).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "format/avatar_unpack.h"
#include "io/ply_3dgs.h"
#include "render/texture_speckle.h"

namespace haha {

struct StorageReport {
  int num_gaussians = 0;
  size_t file_bytes = 0;           // the whole .glb
  size_t avatar_part_bytes = 0;    // Gaussians + texture as stored in the .glb
  size_t ply_3dgs_bytes = 0;       // same Gaussians as a 3DGS .ply (SH degree 0, float32), as `unpack` writes
  size_t ply_3dgs_sh3_bytes = 0;   // same, in the reference trainer's layout (SH degree 3, f_rest zero)
  size_t paper_bytes = 0;          // 56 B x N (float32: 3 pos + 4 rot + 3 scale + 3 colour + 1 opacity)
                                   // + raw 256 x 256 x 3 texture (196,608 B)
  double avatar_part_vs_paper = 0;  // avatar_part_bytes / paper_bytes
  double file_vs_paper = 0;         // file_bytes / paper_bytes
};

inline constexpr size_t kPaperBytesPerGaussian = 56;
inline constexpr size_t kPaperTextureBytes = 256 * 256 * 3;

// The 3DGS .ply sizes are exact: the files are serialised (to a temporary file) through
// io/ply_3dgs.h.
StorageReport storage_report(const UnpackedAvatar& u);

// The avatar's Gaussians in the rest pose (world space, the baked rest mesh's face frames)
// as a standard 3DGS scene: f_dc = (colour - 0.5) / 0.28209479, logit opacity, log scale.
GaussianPly rest_pose_ply(const Avatar& a, int sh_degree = 0);

// The texture's speckle where the video barely looked (render/texture_speckle.h); none
// without a texture or a UV map.
std::optional<TextureSpeckle> avatar_texture_speckle(const Avatar& a);

// Machine-readable summary (`haha info --json`, unpack's summary.json).
nlohmann::json avatar_summary_json(const std::string& path, const UnpackedAvatar& u, const StorageReport& r);
// Human-readable summary (`haha info`).
std::string avatar_summary_text(const std::string& path, const UnpackedAvatar& u, const StorageReport& r);

}  // namespace haha
