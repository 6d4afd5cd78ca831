// A body's rest skeleton at zero betas: what a skeleton file (BVH) or a retargeter needs of
// the body model beyond its parents.
#pragma once

#include <vector>

#include "body/body_model.h"
#include "core/math.h"

namespace haha {

struct RestSkeleton {
  std::vector<Vec3<double>> joints;  // (55) rest joints, metres, haha's Y-up world
  std::vector<int> parents;          // (55), parents[0] = -1
  double sole = 0;                   // height of the lowest rest vertex: where the floor is
};

RestSkeleton rest_skeleton(const BodyModel& body);

}  // namespace haha
