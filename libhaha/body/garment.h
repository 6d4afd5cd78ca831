// A garment around both legs (a skirt, a dress, a coat's tails) as a part of the body mesh:
// its vertices, faces and UVs appended after the body's, with their own skin weights (no
// pose correctives, no shape directions: it is built for one subject's shape) and its own
// chart on the right of the texture (the body's UVs shrink into the left). Face frames, the
// rasterizer, the texture, the trainer and the packer then keep seeing one mesh
// (docs/architecture.md, "garments as parts of one mesh").
//
// The surface is a loft of rings around the pelvis' vertical axis, from the waist to the hem:
// each ring encloses the body's cross-sections at its height (both legs below the crotch)
// with a clearance, the radii never shrink down the garment; the clothed-surface fit
// (train/surface_fit.h) then moves it outward along its normals to the person's silhouette.
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"

namespace haha {

struct Garment {
  std::vector<float> verts;    // (G, 3) rest positions in the subject's shaped rest frame, metres
  std::vector<int32_t> faces;  // (Fg, 3) indices into verts, outward facing
  std::vector<float> weights;  // (G, 55) skin weights, at most four non-zero per vertex, summing to 1
  std::vector<float> vt;       // (Tg, 2) UVs in the atlas (u in [1 - chart, 1], v up)
  std::vector<int32_t> ft;     // (Fg, 3) indices into vt
  float chart = 0;             // share of the texture's width on the right that is the garment's
  int num_verts() const { return int(verts.size() / 3); }
  int num_faces() const { return int(faces.size() / 3); }
  bool empty() const { return verts.empty(); }
};

// Where the loft runs and how it is cut (rest frame, metres).
struct GarmentShape {
  double y_top = 0, y_hem = 0;  // waist and hem heights, y_top > y_hem
  int rings = 14, columns = 48;
  double clearance = 0.01;      // outside the body's cross-section
  float chart = 0.2f;           // share of the texture's width for the garment's chart
  double legs = 0.85;           // the legs' share of the hem's skin weights (garment_skin_weights)
};

// The garment for a body whose shaped rest vertices are `rest` (V, 3) and rest joints `joints`
// (55, 3): rings enclosing the torso's and legs' vertices (arms, hands and head left out), the
// faces, the chart, and skin weights from garment_skin_weights. Throws haha::Error when the
// shape is degenerate (y_top <= y_hem, fewer than 2 rings or 8 columns, no body vertex in
// the range).
Garment build_garment(const BodyModel& body, const std::vector<float>& rest, const std::vector<float>& joints,
                      const GarmentShape& shape);

// The body vertices mostly driven by the torso and the legs (SMPL-X joints 0..11: arms,
// hands and head left out): what a garment encloses and takes its skin weights from.
std::vector<int> garment_source_vertices(const BodyModel& body);

// Skin weights of points `pts` (N, 3) near the body, diffused from the body's (TailorNet's
// rule: inverse distance over the k nearest torso / leg vertices of `rest`), the
// knees', ankles' and feet's weights moved to their hip (cloth hangs from the hips, it does
// not bend at the knee), smoothed `smooth` times over `faces` (the garment's, may be empty),
// then the legs' share (both hips) set to grow from 0 at the points' top to `legs_max` at
// their bottom (linearly in height), split between the legs as diffused, the torso's
// diffused share scaled to the rest (cloth hangs from the waist and the legs push it: a hem
// on the thighs alone swings out with them, one on the pelvis alone lets a stride through;
// game rigs keep 80-90% at the hem's sides), then cut to the four largest and normalised.
// (N, 55).
std::vector<float> garment_skin_weights(const BodyModel& body, const std::vector<float>& rest, const std::vector<float>& pts,
                                        const std::vector<int32_t>& faces, double legs_max = 0.85, int k = 96,
                                        int smooth = 8);

// The body with the garment appended: vertices, faces, UVs (the body's u scaled by
// 1 - chart), weights, zero shape directions, pose correctives and regressor columns, zero
// rest offsets when the body has them. Throws when the body already has a garment or the
// garment's arrays disagree in size.
BodyModel append_garment(const BodyModel& body, const Garment& garment);

// The garment part of a body made by append_garment (empty when it has none), with its own
// indices: append_garment(body without it, garment_of(body)) gives back body.
Garment garment_of(const BodyModel& body);

// Checks a garment's arrays (sizes, indices in range, finite values, weights) for a body of
// `num_joints` joints; throws haha::Error "<where>: garment ..." on the first problem.
void validate_garment(const Garment& g, const char* where);

}  // namespace haha
