// Motion files for `haha render`: a sequence of SMPL-X poses.
//   - AMASS-style .npz: `poses` (T, 165) in SMPL-X order (global | body 21 | jaw | leye |
//     reye | left hand 15 | right hand 15), or (T, 156) SMPL+H (global | body 21 | left
//     hand 15 | right hand 15; jaw and eyes stay 0); `trans` (T, 3); optional
//     `mocap_frame_rate` (or older `mocap_framerate`). Hands are full axis-angle with a flat
//     hand mean, as AMASS stores them.
//   - native SMPL-X parameter files (io/smplx_params_io.h: global_orient, body_pose, ...).
#pragma once

#include <string>
#include <vector>

#include "body/smplx_params.h"

namespace haha {

struct Motion {
  std::vector<SmplxParams> frames;
  double fps = 30.0;  // from the file when it says, else 30
};

// Throws haha::Error "path: key: problem" on bad shapes or non-finite values.
Motion read_motion(const std::string& path);

}  // namespace haha
