// The video fit's initialisation from BlazePose's world points (docs/keypoints.md: metres,
// hip-centred, image-aligned, so directions are in camera axes): the global orient from the
// world hips and shoulders in 3D (which way the body faces, including towards or away from
// the camera, that the 2D torso leaves open), then each upper and lower arm and leg rotated
// from its rest direction onto its world bone direction where both ends are seen. It seeds
// the fit (fit/fit_video.cpp) in place of the 8-heading search, which stays for frames
// without world points.
#pragma once

#include <vector>

#include "fit/fit_video_objective.h"
#include "fit/fit_video_points.h"
#include "body/body_model.h"
#include "core/math.h"

namespace haha {

// Sets the global orient (q[0..2]) and the shoulder, elbow, hip and knee rotations of one
// frame's parameters q (kFitVideoFrameParams; others untouched, the rest are expected 0)
// from tg.world. rest_joints: the body's rest joints (kNumJoints x 3, betas 0); cam_R: the
// camera's world-to-camera rotation. Returns false, q untouched, when the frame has no
// world points or its four torso points are not all seen (visibility >= min_visibility).
bool init_pose_from_world(const BodyModel& body, const std::vector<FitVideoPoint>& points, const FitVideoTargets& tg,
                          const std::vector<float>& rest_joints, const Mat3<double>& cam_R, double min_visibility,
                          float* q);

// The smallest rotation (axis-angle) turning unit vector a onto unit vector b (a half turn
// about an axis perpendicular to a when they are opposite).
Vec3d rotation_between(Vec3d a, Vec3d b);

}  // namespace haha
