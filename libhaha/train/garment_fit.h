// Whether a clip's person wears a garment around both legs (a skirt, a dress, a coat's
// tails), and where its hem is, from the training frames' masks; the garment then made
// (body/garment.h) and appended to the body. Its shape is refined afterwards by the
// clothed-surface fit (train/surface_fit.h), which moves the garment's vertices outward along
// their normals to the silhouettes and never inside the loft it starts from.
//
// The test: at levels down the legs (rest heights from the crotch to the ankles), in each
// frame, the pixels on the image segment between the two legs' posed centres at that level
// (its middle half) that the fitted body does not cover. Trousers or bare legs leave those
// pixels background; a skirt or a dress fills them. `fill` = the share of those pixels
// inside the mask, over all frames. The garment is made when the top levels are filled
// (>= s0.garment.fill) and runs down to the last filled level of the run from the top.
#pragma once

#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/garment.h"
#include "train/config.h"
#include "train/trainer.h"

namespace haha {

struct GarmentDecision {
  std::string mode;          // the request: auto | skirt | none
  bool made = false;         // a garment was made
  std::string why;           // one sentence for the log and the summary
  std::vector<double> t;     // levels down the leg: 0 hip joint, 1 ankle joint
  std::vector<double> fill;  // per level, share of the between-legs pixels in the mask (NaN: no such pixel)
  std::vector<long> pixels;  // per level, how many between-legs pixels were seen
  double y_top = 0, y_hem = 0;  // rest heights of the waist and the hem (when made)
  Garment garment;           // when made
};

// Measures the frames (at most opt.max_frames of them, evenly spread) and decides per
// opt.mode; betas from video_betas. Throws haha::Error "<frame>: ..." for a frame without a
// mask, and for an unknown mode.
GarmentDecision decide_garment(const BodyModel& body, const std::vector<TrainFrame>& frames, const Stage0Config::Garment& opt);

}  // namespace haha
