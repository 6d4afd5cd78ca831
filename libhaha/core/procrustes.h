// Similarity Procrustes alignment of two point sets (rotation, uniform scale, translation;
// Umeyama with Horn's quaternion): the body-joint error after per-frame alignment
// (PA-MPJPE) of the video fit's measurement (fit/fit_video_truth.h) and its tests.
#pragma once

#include <vector>

#include "core/math.h"

namespace haha {

// Mean distance (same units as the input) of points b to points a after the similarity that
// best maps b onto a. a and b have the same size (>= 1); NaN when they do not.
double procrustes_error(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b);

}  // namespace haha
