// The loader of packed avatars: load a .glb, repose it from SMPL-X pose parameters, and
// render it (textured mesh + face-bound Gaussians, merged as in training) or hand the
// posed mesh and Gaussians to the caller's own renderer. Links haha_format, haha_io,
// haha_render and haha_body only (never the trainer).
//
//   haha::AvatarLoader avatar = haha::AvatarLoader::load("avatar.glb");
//   haha::SmplxParams pose;                 // 165 axis-angle values + transl
//   pose.pose[3 * 16 + 2] = -1.0f;       // left shoulder (joint 16) down
//   haha::PosedAvatar posed;
//   avatar.repose(pose, posed);             // posed.verts, posed.means/quats/scales, ...
//   std::vector<float> rgb;                 // (H, W, 3)
//   avatar.render(camera, posed, rgb);
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "body/smplx_params.h"
#include "core/camera.h"
#include "format/animation.h"
#include "render/avatar_render.h"

namespace haha {

// One posed frame. Vectors are resized by repose() and reused across calls.
struct PosedAvatar {
  int num_verts = 0, num_gaussians = 0;
  std::vector<float> verts;   // (V, 3) posed body vertices, world space
  std::vector<float> joints;  // (55, 3) posed joints
  std::vector<float> means;   // (N, 3) Gaussian centres, world space
  std::vector<float> quats;   // (N, 4) world rotations (w, x, y, z)
  std::vector<float> scales;  // (N, 3) world standard deviations (linear)
  const float* colors = nullptr;     // (N, 3) RGB in [0, 1]; pose-independent, owned by the loader
  const float* opacities = nullptr;  // (N) in [0, 1]; likewise
};

struct AvatarRenderOptions {
  float background[3] = {0.0f, 0.0f, 0.0f};
  bool draw_mesh = true;
  bool draw_gaussians = true;
};

// Scratch buffers of render() (the merged render's, render/avatar_render.h), reusable
// across frames so steady-state rendering does not allocate. One per thread.
struct AvatarRenderScratch {
  AvatarRenderBuffers buffers;
};

class AvatarLoader {
 public:
  // Reads and validates a .glb (avatar_unpack.h); throws haha::Error naming the file.
  // `model` (optional): the body model the avatar was trained on, for its pose correctives
  // when the file does not embed them.
  // `max_gaussians` (> 0): of a file with importance tiers (haha pack --lod), load only
  // the tiers that fit (the first always).
  static AvatarLoader load(const std::string& path, const BodyModel* model = nullptr, int max_gaussians = 0);
  // From an in-memory avatar (e.g. straight from the trainer). A body with shape
  // directions is shaped with avatar.betas / avatar.expression; an unpacked (baked) body
  // is used as is, so both repose identically.
  explicit AvatarLoader(Avatar avatar);
  AvatarLoader(AvatarLoader&&) noexcept;
  AvatarLoader& operator=(AvatarLoader&&) noexcept;
  ~AvatarLoader();

  const Avatar& avatar() const;
  int num_verts() const;
  int num_gaussians() const;
  bool has_pose_correctives() const;
  // The avatar was trained with pose correctives but this loader has none (the file did
  // not embed them and set_pose_correctives was not called): reposes then differ from the
  // trainer's under strong poses (measured ~37 dB PSNR on the procedural body).
  bool missing_pose_correctives() const;

  // Uses the pose-corrective blend shapes (posedirs) of `model` (the body model the
  // avatar was trained on) when the file did not embed them. Throws if the vertex count
  // or the faces differ.
  void set_pose_correctives(const BodyModel& model);

  // The file's glTF animations (load() reads them; an in-memory avatar has none until
  // set). Play one with sample_animation / animation_motion (format/animation.h) + repose.
  const std::vector<AvatarAnimation>& animations() const;
  void set_animations(std::vector<AvatarAnimation> animations);

  // Poses the avatar: params.pose (55 x axis-angle, SMPL-X order) and params.transl;
  // params.betas / params.expression are ignored (the subject's own are baked in).
  void repose(const SmplxParams& params, PosedAvatar& out) const;

  // Renders a posed frame into rgb (H, W, 3), H x W = camera size (OpenCV camera,
  // core/camera.h) with the trainer's merged render (render/avatar_render.h):
  // I = C_front + (1 - A) (m M + (1 - m) B), Gaussians behind D + depth_margin hidden.
  void render(const Camera& cam, const PosedAvatar& posed, std::vector<float>& rgb,
              const AvatarRenderOptions& options = {}) const;
  void render(const Camera& cam, const PosedAvatar& posed, std::vector<float>& rgb, const AvatarRenderOptions& options,
              AvatarRenderScratch& scratch) const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace haha
