// Motion files: a sequence of SMPL-X poses with a frame rate, for `haha render --motion`
// and the bench. Two kinds are read:
//   - AMASS: SMPL-X `*_stageii.npz` (poses (T, 165) in SMPL-X order: global | body 21 |
//     jaw | leye | reye | left hand 15 | right hand 15; trans (T, 3); betas;
//     mocap_frame_rate) or SMPL+H (poses (T, 156) = global | body 21 | left hand 15 | right
//     hand 15, no face; mocap_framerate). Hands are full axis-angle with a flat hand mean,
//     used as stored. SMPL+H betas are a different shape space and are dropped; SMPL-X
//     betas are kept. `haha motion` writes this kind.
//   - native SMPL-X parameter files (io/smplx_params_io.h: global_orient, body_pose, ...);
//     frame rate from an optional `mocap_frame_rate` / `fps` scalar, else 30.
#pragma once

#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"

namespace haha {

struct Motion {
  std::vector<SmplxParams> frames;
  double fps = 30;
  std::string source;  // the file it came from
};

// AMASS only. Throws haha::Error "path: key: problem" for wrong shapes, non-finite values,
// a missing trans or a missing frame rate.
Motion read_amass(const std::string& path);

// A motion file of either kind: AMASS (has `poses`) or a native SMPL-X parameter file
// (`model` resolves PCA hand poses there).
Motion read_motion(const std::string& path, const BodyModel* model = nullptr);

}  // namespace haha
