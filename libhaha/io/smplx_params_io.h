// Per-frame SMPL-X parameter files (fits, motions).
#pragma once

#include <string>
#include <vector>

#include "body/smplx_params.h"

namespace haha {

// Reads P.npz with arrays global_orient, body_pose, jaw_pose, leye_pose, reye_pose,
// left_hand_pose, right_hand_pose, betas, expression, transl; each (D) for one frame or
// (N, D) for N frames (betas may be shared: (D) or (1, D)). Missing arrays are zeros.
// Hand poses of 45 values are full axis-angle; fewer values are PCA coefficients and need
// `model` (its hand components; hands_mean is added unless flat_hand_mean).
// Throws on wrong shapes or NaN/Inf values, naming file and key.
std::vector<SmplxParams> read_smplx_params(const std::string& path, const BodyModel* model = nullptr,
                                           bool flat_hand_mean = true);
void write_smplx_params(const std::string& path, const std::vector<SmplxParams>& frames);

}  // namespace haha
