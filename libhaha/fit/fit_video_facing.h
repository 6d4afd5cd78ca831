// Face points seen from behind. When the person turns away from the camera, BlazePose still
// places the nose and eyes (on the back of the head) with full visibility: 0.9998-1 on every
// face point of the synthetic test video's back views (frames 14-26 of 40). Fitted as seen,
// they tilt the head and neck (up to 10 degrees of head pitch and 14 of neck pitch there,
// against the true fits). The video fit (fit/fit_video.cpp) therefore scales their visibility by how far
// the fitted head faces the camera, recomputed from the current fit before each stage and
// held within it, so the objective stays a smooth function of the parameters.
#pragma once

#include <vector>

#include "fit/fit_video_points.h"
#include "core/math.h"

namespace haha {

// c = cos of the angle between the head's forward direction (from the ears' midpoint to the
// nose) and the direction from the nose to the camera: factor 1 at c >= band, 0 at
// c <= -band, linear between (a profile, c near 0, keeps part).
constexpr double kFaceFacingBand = 0.25;

// The factor in [0, 1] of each point of one frame, from the points in camera space (the
// camera at the origin, looking along +z): the facing factor for the nose, eyes and mouth;
// 1 for every other point, and for all of them when the correspondence lacks the nose or
// an ear.
std::vector<double> face_point_factors(const std::vector<FitVideoPoint>& points, const std::vector<Vec3d>& camera_points);

}  // namespace haha
