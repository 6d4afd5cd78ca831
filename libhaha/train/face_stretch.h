// How much each face of the body stretches as the arms move: the input of the stretch
// regulariser (train/losses.h stretch_reg). A face's Gaussians scale and move with its face
// scale k (body/face_frames.h: mu' = k R mu + T, s' = k s). Trained on a capture whose arms
// stay down (an A-pose turn), the faces around the armpits and shoulders never stretch in
// training; when the arms rise they do, and the Gaussians bound to them grow and move out
// with k: a smear under the raised arm. The regulariser keeps those Gaussians small and
// close to their face.
#pragma once

#include <vector>

#include "body/body_model.h"

namespace haha {

// Per face, log(max k / min k) over canonical arm poses of the body shaped by `betas`:
// both arms down in an A-pose (65 degrees below horizontal), in a T-pose, raised 60 degrees
// above horizontal, and straight forward; elbows straight, the rest of the body at rest.
// About 0 on the torso front, legs and head; largest around the armpits and shoulders.
// Degenerate faces (k = 0 in some pose) get 0.
std::vector<float> face_arm_stretch(const BodyModel& body, const std::vector<float>& betas, float face_scale_divisor);

}  // namespace haha
