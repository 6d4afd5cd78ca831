// Internals of the synthetic subject shared by data/synth_*.cpp (not a public API; the
// tests use it to check the pieces).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/math.h"

namespace haha::synth {

using V3 = Vec3<double>;
constexpr double kPi = 3.14159265358979323846;
constexpr int kNeckJoint = 12, kHeadJoint = 15;

// Skirt and ponytail charts of the garment atlas (v up): skirt top at v = kSkirtV0, hem at
// kSkirtV1; ponytail root at kPonytailV0, tip at kPonytailV1; u runs around.
constexpr double kSkirtV0 = 0.98, kSkirtV1 = 0.34, kPonytailV0 = 0.30, kPonytailV1 = 0.02;
constexpr int kSkirtRings = 20, kSkirtColumns = 96;
constexpr double kSkirtPleats = 16;

// Skinning-weight groups that pick a vertex's garment region.
enum Group : int { gTorso, gNeck, gHead, gEye, gLeg, gFoot, gArm, gHand, kGroups };
int joint_group(int joint);

// Landmarks of the shaped rest body, from its joints.
struct Anatomy {
  V3 J[55];
  V3 eye_mid;
  double d = 0.064;  // distance between the eye joints: the face's unit
  double floor_y = 0;
  double waist_y = 0;
};
Anatomy make_anatomy(const std::vector<float>& rest_joints, const std::vector<float>& rest_verts);

double smoothstep(double e0, double e1, double x);
V3 unit(V3 v);
V3 mix(V3 a, V3 b, double t);
double value_noise(V3 p, double cell, uint64_t seed);  // in [0, 1]

double head_azimuth(const Anatomy& a, V3 p);  // 0 = face direction (+Z)
double hair_depth(const Anatomy& a, V3 p);    // metres above the hairline (> 0: hair)
double hair_thickness(const Anatomy& a, V3 p);

struct Palette {
  V3 skin, shirt, trousers, hair, iris, skirt, skirt_dark, skirt_line, shoe, accent, lips, hair_tie;
  uint64_t noise_seed = 0;
};
Palette make_palette(uint64_t seed);

struct SkirtFrame {
  double ref_radius, length;
};

V3 shade_body(const Anatomy& A, const Palette& P, V3 p, V3 n, const double* groups);
V3 shade_skirt(const Palette& P, double t, double phi, double ref_radius, double length);
V3 shade_ponytail(const Palette& P, double s, double theta);
std::vector<V3> vertex_normals(const std::vector<float>& verts, const std::vector<int32_t>& faces);

}  // namespace haha::synth
