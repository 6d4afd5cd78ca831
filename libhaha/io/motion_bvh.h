// A motion as a BVH file of the SMPL-X skeleton, for tools that take mocap (Blender,
// MotionBuilder, game engines). Assimp reads BVH but writes none, so this writes the text.
//   - joints: the 55 SMPL-X joints named as body/joint_names.h, in SMPL-X's hierarchy;
//     OFFSETs from the body's rest joints; an End Site at every leaf (half its own bone on);
//   - units: centimetres, Y up, the body facing +Z (haha's world); the floor (the body's
//     rest soles) at y = 0;
//   - channels: the root "Xposition Yposition Zposition Zrotation Yrotation Xrotation",
//     every other joint "Zrotation Yrotation Xrotation", degrees: a joint's local rotation
//     is Rz * Ry * Rx, the SMPL-X joint's axis-angle exactly (rest rotations are identity).
#pragma once

#include <string>

#include "body/rest_skeleton.h"
#include "io/motion.h"

namespace haha {

// `m` must be in haha's Y-up world (motion_to_y_up). The text of the whole file.
std::string motion_bvh_text(const Motion& m, const RestSkeleton& rest);

// Writes motion_bvh_text atomically; haha::Error naming the file on failure.
void write_motion_bvh(const Motion& m, const RestSkeleton& rest, const std::string& path);

// Z, Y, X Euler angles (radians) of R = Rz(z) Ry(y) Rx(x); the inverse of euler_zyx_matrix.
Vec3<double> matrix_to_euler_zyx(const Mat3<double>& R);
Mat3<double> euler_zyx_matrix(const Vec3<double>& zyx);

}  // namespace haha
