// SMPL -> SMPL-X by fitting (PeopleSnapshot's SMPL poses, `haha convert --from
// peoplesnapshot`). SMPL and SMPL-X have different templates and root joints, so copying
// angles and transl leaves the body centimetres off. Instead, per frame SMPL-X global
// orient, body pose (21 joints) and transl, plus betas shared by all frames, are fitted to
// the posed SMPL body: its joints 0-21 (same meaning in both models) and, where a vertex
// correspondence is given, its vertices. Both bodies are posed with our LBS (body/lbs.h,
// SMPL through the 55-joint layout of io/smpl_model_io.h), gradients from its backward,
// Adam with a log-linear learning-rate decay (train/adam.h).
//
// Loss per frame: mean over joints 0-21 of |J_x - J_smpl|^2 + mean over corresponded
// vertices of |v_x - v_smpl|^2 (+ prior * |pose - initial pose|^2 on the body pose, which
// fixes the bone twists that joints alone leave free when there is no correspondence).
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"

namespace haha {

struct SmplFitOptions {
  int iterations = 500;
  int num_betas = 10;          // SMPL-X betas fitted (shared by all frames)
  double lr_pose = 0.02, lr_transl = 0.01, lr_betas = 0.05;  // radians / metres / units, decayed
  double lr_final_factor = 0.05;                               // to this fraction at the end
  double pose_prior = -1;      // < 0: 0 with a correspondence, 1e-4 without
  bool progress = true;        // print the residual every 50 iterations
};

struct SmplFitResult {
  std::vector<SmplxParams> frames;     // SMPL-X (hands, jaw, eyes at rest; shared betas)
  std::vector<double> joint_mm;        // per frame: mean distance of joints 0-21, mm
  std::vector<double> vertex_mm;       // per frame: mean distance of corresponded vertices, mm (empty: none)
};

// smpl: an SMPL model in the 55-joint layout (load_smpl_model); smplx: the SMPL-X model.
// smpl_to_smplx: for each SMPL vertex its SMPL-X vertex or -1 (empty: joints only).
// smpl_frames: SMPL parameters (smpl_params()). init: SMPL-X starting point (empty: the
// SMPL joint angles of joints 0-21 and a transl that puts the pelvis on SMPL's).
// Throws haha::Error for mismatched sizes.
SmplFitResult fit_smplx_to_smpl(const BodyModel& smpl, const BodyModel& smplx, const std::vector<int32_t>& smpl_to_smplx,
                                const std::vector<SmplxParams>& smpl_frames, const std::vector<SmplxParams>& init = {},
                                const SmplFitOptions& opt = {});

}  // namespace haha
