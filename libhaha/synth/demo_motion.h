// Short procedural SMPL-X motions for reposing a trained avatar with poses it never saw in
// training (the synthetic subject trains on turning in place with lowered arms): `haha
// motion` writes them, the demo renders the wave.
//   wave  facing the camera, swaying a little, the right forearm up and waving from the
//         elbow, the left arm hanging; looks to both sides once
//   walk  walking in place, two strides per loop, turning a quarter each way
//   turn  a full turn with the arms half lowered and the knees slightly bent
//   kick  facing the camera, a high front kick with the left then the right leg (hip
//         flexed 80 degrees), arms out: the test of a skirt's skinning
// Rotations are SMPL-X local rotations in the rest (T-pose) frame, the facts of
// synth/synth_motion.cpp.
#pragma once

#include <string>
#include <vector>

namespace haha {

// The kNumPoseValues pose values at phase s in [0, 1) of `kind` (the motions loop). Throws
// haha::Error "--kind: unknown motion ..." for another kind.
std::vector<float> demo_motion_pose(const std::string& kind, double s);

}  // namespace haha
