// The trained avatar as an .npz (RUN/avatar.npz, written by the trainer's driver and read
// by `haha pack`; the run directory's layout is app/run_dir.h). The body model is not in
// it: the run's config.json names it.
//
// avatar.npz keys (float32 unless noted; N Gaussians, values ACTIVATED, not logits):
//   format_version      int32 (1)            = 1
//   betas               (B)                  subject shape
//   expression          (E)                  subject expression (may be empty: shape (0))
//   face_scale_divisor  (1)                  k divisor of the face frames (release: 0.05)
//   depth_margin        (1)                  metres of the merge's depth test (optional; 0)
//   texture             (H, W, 3)            RGB in [0, 1], row 0 = top (v = 1)
//   gaussian_face       int32 (N)            parent face index
//   gaussian_offset     (N, 3)               local mean mu
//   gaussian_rotation   (N, 4)               local unit quaternion (w, x, y, z)
//   gaussian_scale      (N, 3)               > 0, in units of the face scale k
//   gaussian_color      (N, 3)               RGB in [0, 1]
//   gaussian_opacity    (N)                  [0, 1]
//   rest_offsets        (V, 3)               the body's rest displacement (optional; none)
//   mesh_coverage       (V)                  [0, 1] per body vertex, garment included
//                                            (optional; absent: the whole mesh draws)
#pragma once

#include <string>

#include "body/avatar.h"

namespace haha {

inline constexpr int kAvatarNpzVersion = 1;

// Writes everything but the body (atomic). Throws haha::Error on inconsistent sizes or
// non-finite values.
void save_avatar_npz(const Avatar& avatar, const std::string& path);

// Reads avatar.npz; the returned body is empty but for its rest_offsets, and `garment` holds
// the garment the run appended to the body (body/garment.h), if any. Shapes,
// finiteness and value ranges are checked ("path: key: problem"); face indices are checked
// once a body is attached.
Avatar load_avatar_npz(const std::string& path);

// Makes `body` (the model the run was trained on) with the avatar's garment appended the
// avatar's, keeping the rest displacement the avatar.npz carried. Throws "path: rest_offsets: ..." when its vertex
// count is not the model's.
void attach_body(Avatar& avatar, BodyModel body, const std::string& path);

// A garment alone (the run directory's garment.npz: what a resumed run appends again), under
// the same keys as in avatar.npz. Both check it (validate_garment).
void save_garment_npz(const Garment& garment, const std::string& path);
Garment load_garment_npz(const std::string& path);

}  // namespace haha
