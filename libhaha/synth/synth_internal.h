// Internals of the synthetic subject shared by data/synth_*.cpp (not a public API; the
// tests use it to check the pieces).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "core/image.h"
#include "core/math.h"
#include "synth/synth_subject.h"

namespace haha::synth {

using V3 = Vec3<double>;
constexpr double kPi = 3.14159265358979323846;
constexpr int kNeckJoint = 12, kHeadJoint = 15;

// Skirt and ponytail charts of the garment atlas (v up): skirt top at v = kSkirtV0, hem at
// kSkirtV1; ponytail root at kPonytailV0, tip at kPonytailV1; u runs around.
constexpr double kSkirtV0 = 0.98, kSkirtV1 = 0.34, kPonytailV0 = 0.30, kPonytailV1 = 0.02;
constexpr int kSkirtRings = 20, kSkirtColumns = 96;
constexpr double kSkirtPleats = 16;
// Subject 2's long hair sheet: rows from the top down, kLongHairColumns + 1 vertices each.
constexpr int kLongHairRows = 30, kLongHairColumns = 36;

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

// Material response to view-dependent shading (SynthMesh::gloss).
constexpr float kHairGloss = 0.7f, kClothGloss = 1.0f;

// Mild view-dependent shading of colour c at a surface point with unit normal n seen along
// the unit vector v toward the camera (world space), strength s >= 0: a rim sheen
// (grazing views brighter) and a specular highlight of a fixed world light. Both depend on
// the view, so a diffuse texture cannot hold them. s = 0 returns c unchanged. Two-sided:
// n is flipped toward the viewer (garment sheets are seen from both sides).
V3 view_shade(V3 c, V3 n, V3 v, double s);

V3 shade_body(const Anatomy& A, const Palette& P, V3 p, V3 n, const double* groups);
V3 shade_skirt(const Palette& P, double t, double phi, double ref_radius, double length);
V3 shade_ponytail(const Palette& P, double s, double theta);
std::vector<V3> vertex_normals(const std::vector<float>& verts, const std::vector<int32_t>& faces);

// ---------------------------------------------------------------------------------------
// Building blocks shared by the subjects (synth_subject.cpp).

std::vector<std::array<double, kGroups>> vertex_groups(const BodyModel& body);
// Skinning weights: add_weight entries, then end_vertex normalises them to sum 1.
void add_weight(SynthMesh& m, int joint, double w);
void end_vertex(SynthMesh& m);
// Faces of an R x (C + 1) vertex grid (row i, column k at i (C + 1) + k): (i,k) -> (i+1,k)
// -> (i,k+1) and its partner per cell, so rings going down with phi growing face outward.
void add_grid_faces(SynthMesh& m, int R, int C);
// Candidates lying inside another connected component of (verts, faces).
std::vector<uint8_t> inside_other_part(const std::vector<float>& verts, const std::vector<int32_t>& faces,
                                       const std::vector<int>& candidates);
// Shell over the body vertices with offset(v, rest position) > 1e-4 (metres along the
// normal); `source` (optional) receives the body vertex of each shell vertex.
SynthMesh make_shell(const BodyModel& body, const std::vector<float>& rest, const std::vector<V3>& normals,
                     const std::function<double(int, V3)>& offset, std::vector<int>* source = nullptr);
SynthMesh make_hair(const BodyModel& body, const Anatomy& A, const std::vector<float>& rest,
                    const std::vector<V3>& normals, const std::vector<std::array<double, kGroups>>& groups);
std::vector<double> radial_extent(const std::vector<float>& verts, const std::vector<int32_t>& faces,
                                  const std::vector<int>& tris, double axis_x, double axis_z,
                                  const std::vector<double>& plane_y, const std::vector<double>& phis);

// A flared skirt (subject 1's skirt, subject 2's coat tails): garment chart v from
// kSkirtV0 (top) to kSkirtV1 (hem), u around from the back seam.
struct SkirtSpec {
  std::string name = "skirt";
  unsigned part = kSynthSkirt;
  float gloss = kClothGloss;
  double y_top = 0, y_hem = 0;
  double clearance = 0.012;   // metres outside the body's extent
  double flare = 0.10;        // extra radius at the hem (grows as t^1.5)
  double pleat_depth = 0.018, pleats = kSkirtPleats;
  double legs = 0.7;          // share of the hips' rotation at the hem
  double legs_full_at = 1.0;  // t (0 top, 1 hem) where the hips' share reaches `legs`
  double leg_blend = 0.06;    // half-width (m) of the left/right thigh blend across the middle
  int rings = kSkirtRings, columns = kSkirtColumns;
};
SynthMesh make_skirt(const SkirtSpec& spec, const Anatomy& A, const std::vector<float>& rest,
                     const std::vector<int32_t>& faces, const std::vector<std::array<double, kGroups>>& groups,
                     SkirtFrame* frame);

// s.rest_verts / s.rest_joints from s.betas.
void shape_rest(const BodyModel& body, SynthSubject& s);
// Body atlas painted from shade(rest point, unit normal, group weights).
void paint_body_texture(const BodyModel& body, SynthSubject& s, const std::vector<V3>& normals,
                        const std::vector<std::array<double, kGroups>>& groups, int S,
                        const std::function<V3(V3, V3, const double*)>& shade);
// Garment atlas (S x S/2) of the two charts: upper(t, u) above (t from 0 at kSkirtV0 to 1
// at kSkirtV1: skirt / coat tails), lower(s, u) below (s from 0 at kPonytailV0 to 1 at
// kPonytailV1: ponytail / long hair); u in [0, 1) runs around.
void paint_garment_texture(Image& tex, int S, const std::function<V3(double, double)>& upper,
                           const std::function<V3(double, double)>& lower);
void paint_atlas(Image& tex, const float* vt, const int32_t* ft, const std::vector<int32_t>& faces_to_paint, int ss,
                 const std::function<V3(int, double, double, double)>& shade);

// Subject 2 (synth_subject_coat.cpp); options already validated.
SynthSubject make_coat_subject(const BodyModel& body, const SynthSubjectOptions& opt);

}  // namespace haha::synth
