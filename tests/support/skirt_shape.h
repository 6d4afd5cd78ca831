// The skirt the garment tests put on a body: from halfway between the pelvis and spine1
// joints (the waist) to 80% of the way from the hip joints to the knees, in the rest frame.
#pragma once

#include <vector>

#include "body/body_model.h"
#include "body/garment.h"

namespace haha::test {

// `joints`: the body's (55, 3) rest joints.
inline GarmentShape skirt_shape(const std::vector<float>& joints) {
  GarmentShape s;
  const double hip = 0.5 * (joints[4] + joints[7]), knee = 0.5 * (joints[13] + joints[16]);
  s.y_top = 0.5 * (joints[1] + joints[10]);
  s.y_hem = hip + 0.8 * (knee - hip);
  return s;
}

}  // namespace haha::test
