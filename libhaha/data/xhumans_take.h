// Writes a dataset (e.g. the synthetic subject of `haha synth`) as X-Humans takes, in the
// layout read_xhumans (data/readers.h) takes and docs/method.md section 6 describes, so the
// real-data path runs end to end without the licence-gated data:
//   TAKE/render/image/color_%06d.png   the frame centred on a width x height canvas
//                                      (X-Humans: 800 x 1200; padding black)
//   TAKE/render/depth/depth_%06d.tiff  float32 millimetres: on the person (mask >= 0.5) the
//                                      camera depth of the posed pelvis (the synthetic
//                                      subject has no depth render), elsewhere the far
//                                      background, far_mm behind it, so that the release's
//                                      rule depth.max() - depth > 700 gives the mask back
//   TAKE/render/cameras.npz            intrinsic (3, 3) OpenCV (pixel centres at integers),
//                                      extrinsic (N, 4, 4) world -> camera, frame order
//   TAKE/SMPLX/mesh-f%05d_smplx.pkl    pickled dict of float32 1-D arrays: global_orient 3,
//                                      transl 3, body_pose 63, left/right_hand_pose 45 (full
//                                      axis-angle), jaw/leye/reye_pose 3, expression 10, betas 10
// Frames are numbered from 1 in each take, as X-Humans does. The frame must fit the canvas
// with an even margin, and the camera must be static (one intrinsic per take).
#pragma once

#include <string>

#include "body/body_model.h"
#include "data/dataset.h"

namespace haha {

struct XHumansTakeOptions {
  int width = 800, height = 1200;  // X-Humans' frame size
  double far_mm = 3000;            // background depth behind the person
};

// Writes the frames of `split` of `ds` (pixels loaded through its loader) into take_dir.
// `body` poses the fits for the depth. Throws haha::Error naming the take or the frame.
void write_xhumans_take(Dataset& ds, Split split, const BodyModel& body, const std::string& take_dir,
                        const XHumansTakeOptions& opt = {});

}  // namespace haha
