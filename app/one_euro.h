// The one-euro filter (Casiez, Roussel, Vogel, CHI 2012): a low-pass whose cutoff rises with
// the signal's speed, so a still signal loses its jitter and a fast move keeps its speed,
// for vectors and for rotations (unit quaternions, filtered on the sphere). Run forwards
// and backwards and averaged, so an offline clip gets no lag (`haha motion --from-video`).
#pragma once

#include <vector>

#include "core/math.h"

namespace haha {

struct OneEuroParams {
  // Casiez et al.'s suggested start: a 1 Hz cutoff at rest; beta raises it by beta Hz per
  // unit of speed (m/s for positions, rad/s for rotations); the speed itself low-passed at 1 Hz.
  double min_cutoff_hz = 1.0;
  double beta = 0.5;
  double d_cutoff_hz = 1.0;
};

// x sampled at `fps`; returns the zero-lag filtered sequence (same size).
std::vector<Vec3<double>> one_euro(const std::vector<Vec3<double>>& x, double fps, const OneEuroParams& p);
std::vector<Quat<double>> one_euro(const std::vector<Quat<double>>& q, double fps, const OneEuroParams& p);

}  // namespace haha
