// How far the body pokes through its garment in a pose: the check a skirt's skinning has to
// pass in a walk or a kick (the garment is skinned from the body, the legs are not bound to
// stay inside it).
//
// The body vertices checked are those the garment covers at rest (inside it, nearest to a
// point of its surface that is not on the waist or hem edge); in a pose, one of them is
// outside when it lies on the outer side of the nearest garment face, by that face's normal.
#pragma once

#include <vector>

#include "body/body_model.h"

namespace haha {

struct GarmentClearance {
  int covered = 0;        // body vertices the garment covers at rest
  int outside = 0;        // of those, outside the garment in the pose
  double max_depth = 0;   // the deepest outside, metres (0 when none is)
  double mean_depth = 0;  // mean over the outside ones, metres
  double share() const { return covered > 0 ? double(outside) / covered : 0.0; }
};

// The body vertices (of garment_source_vertices) the garment covers in `rest` (num_verts x 3,
// the avatar posed at the zero pose). Empty when the body has no garment.
std::vector<int> garment_covered_vertices(const BodyModel& body, const float* rest);

// The clearance of `covered` in `posed` (num_verts x 3, the same avatar in some pose).
GarmentClearance garment_clearance(const BodyModel& body, const std::vector<int>& covered, const float* posed);

}  // namespace haha
