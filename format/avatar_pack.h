// Avatar -> .glb (format/spec.md). The file is a standard skinned, textured glTF 2.0 mesh
// (Draco-compressed, or plain accessors that any glTF reader opens) plus the
// HAHA_gaussian_avatar extension holding the face-bound Gaussians (a Draco point cloud,
// their faces named in the canonical face order, so tools may rewrite the mesh) and what
// a loader needs to repose and render them exactly like the trainer.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "format/animation_pack.h"
#include "format/image_codec.h"
#include "format/pose_correctives_codec.h"

namespace haha {

inline constexpr const char* kAvatarExtension = "HAHA_gaussian_avatar";
// Version 2: edgebreaker meshes (faces in the encoder's order, FACE_CORNER), rest joints
// from the inverse bind matrices when there is no joint regressor, optional normals.
// Version 3: Draco-free meshes, the public _BODY_VERTEX attribute, Gaussians bound to the
// canonical face order (any tool may reorder the mesh), weights summing exactly to one,
// skinned KHR_gaussian_splatting splats.
// Version 4: a garment is primitive 1 of the body mesh (version 3 kept it inside primitive
// 0); the body's faces are primitive 0's triangles followed by primitive 1's.
inline constexpr int kAvatarFormatVersion = 4;
inline constexpr int kOldestAvatarFormatVersion = 1;  // readers still load version 1

// Draco quantization bits per Gaussian attribute; 0 = raw float32 (bit-exact).
// Defaults chosen on the trained demo avatar (`haha bench --gaussian-bit-sets`, 8,887
// Gaussians, renders of the unpacked file vs the trained avatar on the test poses):
// 8/6/6/6/5 bits = 7.9 B per Gaussian at 59.9 dB; the former 12/10/8/7/7 = 12.4 B at
// 62.1 dB; uniform 6 bits 7.3 B at 55.0 dB. One bit less from 8/6/6/6/6 (60.0 dB):
// offset 9 -> 8 cost 0.55 dB, scale 6 -> 5 0.49 dB, opacity 6 -> 5 0.16 dB (docs/results.md).
struct GaussianBits {
  int offset = 8;     // local offset, uniform over its bounding box
  int rotation = 6;   // "smallest three" quaternion components in [-1/sqrt 2, 1/sqrt 2]
  int scale = 6;      // log(scale), uniform over its range
  int color = 6;      // RGB in [0, 1]
  int opacity = 5;    // [0, 1]
};

// Draco quantization bits of the glTF mesh; 0 = raw float32.
struct MeshBits {
  int position = 16;  // 15 bits already cost ~6 dB: Gaussians sit at the surface, and the
                      // depth test against the mesh flips with sub-0.1 mm moves
  int normal = 8;     // octahedral; normals only serve lit viewers (PackOptions::normals)
  int texcoord = 12;
  int weight = 10;
};

// "14" (every attribute) or "offset=14,rotation=12" (the others keep `base`); throws
// haha::Error naming `option` on an unknown key or a value outside 0..30.
GaussianBits parse_gaussian_bits(const std::string& text, const std::string& option, GaussianBits base = {});
MeshBits parse_mesh_bits(const std::string& text, const std::string& option, MeshBits base = {});

// Which pose correctives a file embeds (spec section 3, body.poseCorrectives).
enum class PoseCorrectives {
  none,     // a loader needs the body model to repose like the trainer
  compact,  // "sparse_lowrank" (format/pose_correctives_codec.h): a few kB, the default
  dense,    // every value: int16 with a per-feature scale, float32 with `lossless` (large)
};

// How the body mesh is stored (format/spec.md section 2).
enum class MeshCompression {
  draco,  // KHR_draco_mesh_compression, a required extension: about 3x smaller
  none,   // plain accessors, no required extension: any glTF reader (Blender, Godot) opens it
};

struct PackOptions {
  // Raw float32 everywhere, a float32 copy of the texture and of the UVs: every trained
  // parameter and every stored body array comes back bit-exact. Ignores the bit settings.
  bool lossless = false;
  GaussianBits gaussian_bits;
  MeshBits mesh_bits;
  // JPEG (4:4:4, quality 90) by default: every glTF viewer reads it, and on the trained
  // demo avatar q90 with the embedded correctives stays above the 45 dB budget (q85 did
  // not; docs/results.md "Storage"); png is lossless 8-bit; webp is smaller but makes
  // EXT_texture_webp a required extension.
  TextureCodec texture_codec = TextureCodec::jpg;  // webp q95 is smaller but fell below 45 dB on a trained texture (haha bench)
  int texture_quality = 0;   // jpg / webp 1..100; 0 = default_texture_quality() of the packed texture's side
  int texture_size = 0;      // 0 = the trained size; else a square N x N resample
  // Adds a KHR_gaussian_splatting POINTS primitive with the Gaussians in the rest pose
  // (for splat-aware viewers). Note: the Khronos validator (2.0.0-dev.3.10) reports its
  // attribute names as errors; see spec.md.
  bool khr_gaussian_splatting = false;
  // Pose-corrective blend shapes (posedirs) of the body, so the loader reposes like the
  // trainer without the body model. Lossy packs embed them compactly by default; lossless
  // packs embed nothing unless `dense` (float32, exact) is asked for. Bodies without
  // posedirs embed nothing.
  PoseCorrectives pose_correctives = PoseCorrectives::compact;
  PoseCorrectiveCodec pose_corrective_codec;
  // Lossy mode drops skinning weights below this and renormalises (lossless keeps all).
  float min_skin_weight = 1e-4f;
  MeshCompression mesh_compression = MeshCompression::draco;
  // Draco's sequential mesh encoding, which keeps the body's face order (about 3x larger
  // than edgebreaker). Lossless packs always use it.
  bool keep_face_order = false;
  // Vertex normals in the mesh. The material is unlit, so viewers do not need them (glTF
  // viewers compute flat normals where a lit material asks); off by default.
  bool normals = false;
  // Levels of detail: the Gaussians in this many importance tiers, one point cloud each,
  // prefixes N/2^(T-1), ..., N (format/gaussian_lod.h); 1 = one point cloud.
  int lod_tiers = 1;
  // glTF animations of the joint nodes (format/animation_pack.h), after every other part:
  // without them the file is byte for byte what it was before animations existed.
  std::vector<AnimationSource> animations;
  int animation_bits = kDefaultAnimationRotationBits;  // per rotation component: 16, 8 or 0 (float32)
};

// The jpg / webp quality a texture of side `side` is packed at by default: 90 up to 512^2
// (the demo's 256^2 texture stays above the 45 dB budget there, q85 did not), 75 above: a
// 1024^2 texture holds four times the texels, and at q75 the taiji.mp4 avatar keeps
// 50.1 dB against the trained one in 265 KB instead of 365 KB at q90 (docs/results.md
// "Sharp at 512 px").
int default_texture_quality(int side);

// Bytes per part of a packed file (what `haha info` and the storage report show).
struct PackedSizes {
  size_t total = 0;
  size_t json = 0;
  size_t mesh = 0;            // Draco mesh (positions, normals, UVs, skin, vertex map)
  size_t skeleton = 0;        // inverse bind matrices (+ joint regressor in lossless packs)
  size_t gaussians = 0;       // Draco point cloud of the Gaussians
  size_t texture = 0;         // encoded image
  size_t texture_exact = 0;   // float32 texture copy (lossless only)
  size_t pose_correctives = 0;
  size_t splats = 0;          // KHR_gaussian_splatting primitive
  size_t animations = 0;      // glTF animations (key times, translations, rotations)
  int num_gaussians = 0;
  int num_vertices = 0;       // glTF vertices (body vertices split at UV seams)
  int num_faces = 0;
  int skin_sets = 0;          // JOINTS_n/WEIGHTS_n sets shipped
  int max_influences = 0;     // largest number of nonzero weights of a vertex in the body
  bool edgebreaker = false;   // mesh encoded with edgebreaker (faces in the encoder's order)
  bool draco_mesh = false;    // mesh compressed with KHR_draco_mesh_compression
  int lod_tiers = 0;          // Gaussian tiers stored (0: one point cloud)
};

// Packs the avatar. Throws haha::Error ("avatar: <problem>") on invalid input (sizes,
// NaN/Inf, face index out of range, missing UV map, ...).
std::vector<uint8_t> pack_avatar(const Avatar& avatar, const PackOptions& options, PackedSizes* sizes = nullptr);

// pack_avatar + atomic write.
PackedSizes write_avatar_glb(const Avatar& avatar, const std::string& path, const PackOptions& options);

// Rest-shape vertices (V, 3) of the avatar's bare body: v_template + shapedirs . [betas,
// expression], accumulated in double; the rest joints are regressed from these. A body
// without (non-zero) shapedirs is taken as already baked (its betas are metadata only).
// Throws if betas/expression are longer than the model's.
std::vector<float> shaped_rest_vertices(const Avatar& avatar);
// The rest vertices (V, 3) the file stores: shaped_rest_vertices plus the body's rest
// displacement (BodyModel::rest_offsets), when it has one.
std::vector<float> baked_rest_vertices(const Avatar& avatar);

}  // namespace haha
