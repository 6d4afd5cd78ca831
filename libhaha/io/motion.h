// Motion files: a sequence of SMPL-X poses with a frame rate, for `haha render --motion`,
// the loader and the bench. Two kinds are read:
//   - AMASS: SMPL-X `*_stageii.npz` (poses (T, 165) in SMPL-X order: global | body 21 |
//     jaw | leye | reye | left hand 15 | right hand 15; trans (T, 3); betas; gender;
//     mocap_frame_rate) or SMPL+H (poses (T, 156) = global | body 21 | left hand 15 | right
//     hand 15, no face; mocap_framerate). Hands are full axis-angle with a flat hand mean,
//     used as stored (docs/method.md section 6). SMPL+H betas are a different shape space
//     and are dropped; SMPL-X betas are kept. AMASS's world is Z-up: the frames come back
//     as stored, with `up` = +Z, and motion_to_y_up() turns them into haha's Y-up world
//     once the body's rest pelvis is known. A file may say otherwise with an `up` (3,)
//     array; `haha motion` writes (0, 1, 0).
//   - native SMPL-X parameter files (io/smplx_params_io.h: global_orient, body_pose, ...),
//     Y-up; frame rate from an optional `mocap_frame_rate` / `fps` scalar, else 30.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "core/math.h"

namespace haha {

struct Motion {
  std::vector<SmplxParams> frames;
  double fps = 30;
  std::string source;               // the file it came from
  std::string gender;               // "male", "female", "neutral" when the file says; else empty
  int pose_width = 0;               // values per frame in the file: 165 SMPL-X, 156 SMPL+H, 0 native
  std::array<double, 3> up{0, 1, 0};  // world up of `frames` (unit); haha's world is +Y
};

// AMASS only. Throws haha::Error "path: key: problem" for wrong shapes, non-finite values,
// a missing trans or a missing frame rate.
Motion read_amass(const std::string& path);

// A motion file of either kind: AMASS (has `poses`) or a native SMPL-X parameter file
// (`model` resolves PCA hand poses there). Frames as stored (see `up`).
Motion read_motion(const std::string& path, const BodyModel* model = nullptr);

// Rotates every frame by the smallest rotation R taking m.up to +Y, about the world
// origin, and sets m.up = +Y. A posed body turns rigidly with its world when
//   root' = R root,  transl' = R (J0 + transl) - J0,
// where J0 is the rest pelvis joint of the body that will be posed (it depends on the
// betas: the posed pelvis is J0 + transl), so the caller passes it in (e.g. the pelvis of
// a repose at zero pose and zero transl). No-op when m.up is already +Y.
void motion_to_y_up(Motion& m, const std::array<double, 3>& rest_pelvis);

// Shortest-arc spherical interpolation between unit quaternions (w, x, y, z), s in [0, 1];
// the result is unit. The one slerp of motions: resample_motion and the .glb animations'
// LINEAR rotation channels (format/animation.h) both use it.
Quat<double> slerp_shortest(Quat<double> a, Quat<double> b, double s);

// The motion resampled to `fps` over the same duration: frame k at time k / fps (the last
// at or before the last source frame). Joint rotations are slerped between the two source
// frames around that time (shortest arc), transl, betas and expression interpolated
// linearly. Throws for fps <= 0 or a motion without frames.
Motion resample_motion(const Motion& m, double fps);

}  // namespace haha
