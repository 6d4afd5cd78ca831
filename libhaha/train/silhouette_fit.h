// A pose pre-fit to the person masks (before stage 1): per frame, global orient, body pose
// and transl move so that the body's antialiased silhouette (render/mesh_antialias.h) lies
// inside the mask and covers it. Clothes and hair make the mask larger than the body, so the
// two sides weigh differently: body outside the mask costs `w_outside`, mask left uncovered
// costs `w_inside` (small); both are means over the pixels. A prior `w_prior` on the squared
// change from the given fit holds the joints a silhouette does not constrain. Opt-in
// (`s0.steps`).
#pragma once

#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "train/trainer.h"

namespace haha {

struct SilhouetteFitReport {
  std::vector<double> loss_start, loss_end;  // per frame
};

// Updates every frame's params in place (betas and expression untouched).
SilhouetteFitReport fit_poses_to_masks(const BodyModel& body, std::vector<TrainFrame>& frames,
                                       const Stage0Config& opt);

}  // namespace haha
