// The SMPL-X body model as loaded from SMPLX_{NEUTRAL,MALE,FEMALE}.npz (or the procedural
// stand-in written by `haha synth-body`, which uses exactly the same file layout).
// All arrays are float32, row-major, structure of arrays. Layout facts:
// docs/method.md section 5.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace haha {

constexpr int kNumJoints = 55;       // pelvis, 21 body, jaw, 2 eyes, 2 x 15 fingers
constexpr int kNumPoseValues = 165;  // 55 joints x axis-angle
constexpr int kNumPoseFeatures = 486;  // 54 x 9 pose-corrective features

// Offsets (in joints) of the pose groups inside the 55-joint pose vector.
enum PoseJoint : int {
  kGlobalOrient = 0,
  kBodyFirst = 1,    // 21 body joints: 1..21
  kJaw = 22,
  kLeftEye = 23,
  kRightEye = 24,
  kLeftHandFirst = 25,   // 15 joints: 25..39
  kRightHandFirst = 40,  // 15 joints: 40..54
};

struct BodyModel {
  std::string source;  // file it was loaded from (for error messages)
  int num_verts = 0;
  int num_faces = 0;
  int num_shape = 0;  // shape (betas) columns available in shapedirs
  int num_expr = 0;   // expression columns available in shapedirs

  std::vector<float> v_template;   // (V, 3)
  std::vector<int32_t> faces;      // (F, 3)
  std::vector<float> j_regressor;  // (55, V) dense, as in the file
  // (55, 3) fixed rest joints, used instead of j_regressor when that is empty. Only for a
  // body whose shape is baked (no shapedirs): an unpacked avatar file without a regressor.
  std::vector<float> joints_rest;
  std::vector<int32_t> parents;    // (55), parents[0] = -1
  std::vector<float> weights;      // (V, 55) skinning weights
  // (V, 3, num_shape + num_expr): columns 0..num_shape-1 shape, then expression.
  std::vector<float> shapedirs;
  std::vector<float> posedirs;     // (V, 3, 486)
  // (V, 3) or empty: a subject's displacement of the rest surface (SMPL+D: the clothed
  // person, not the bare body; train/surface_fit.h), added to the shaped rest vertices
  // after the joint regression, so the joints, the skinning and the correctives stay the
  // body's. Not part of a model file: the trainer fits it, the run and the .glb carry it.
  std::vector<float> rest_offsets;

  // A garment appended after the body (body/garment.h): vertices, faces and UVs from these
  // indices on are the garment's; 0 = none (every vertex is the body's). `garment_chart`:
  // the share of the texture's width, on the right, that is the garment's chart.
  int garment_first_vert = 0, garment_first_face = 0, garment_first_uv = 0;
  float garment_chart = 0;
  bool has_garment() const { return garment_first_vert > 0; }
  int num_body_verts() const { return has_garment() ? garment_first_vert : num_verts; }
  int num_body_faces() const { return has_garment() ? garment_first_face : num_faces; }

  // Hand PCA (45 x 45 components, 45 means) for fits that store PCA coefficients.
  std::vector<float> hands_components_l, hands_components_r;  // (45, 45)
  std::vector<float> hands_mean_l, hands_mean_r;              // (45)

  std::vector<int32_t> lmk_faces_idx;    // (L)
  std::vector<float> lmk_bary_coords;    // (L, 3)

  std::vector<float> vt;          // (T, 2) UV coordinates, v up (OpenGL texture convention)
  std::vector<int32_t> ft;        // (F, 3) UV index per face corner

  int num_uv() const { return int(vt.size() / 2); }
};

}  // namespace haha
