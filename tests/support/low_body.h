// The procedural body at low resolution (seed 0), built once per test program: the small
// SMPL-X-layout body most tests pose.
#pragma once

#include "body/procedural_body.h"

namespace haha::test {

inline const BodyModel& low_body() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 0});
  return b;
}

}  // namespace haha::test
