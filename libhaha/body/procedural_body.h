// A procedural human body written in the SMPL-X model layout, so that every tool that
// takes SMPLX_NEUTRAL.npz also runs on it (the real file is licence-gated and never
// shipped). Same keys and shapes: 55 joints with the SMPL-X parents, J_regressor (55, V),
// weights (V, 55), shapedirs (V, 3, 300 shape + 100 expression), posedirs (V, 3, 486),
// hand PCA (45 x 45, orthonormal rows), 51 facial landmarks, a UV atlas with seams.
//
// Conventions of the SMPL-X rest pose: metres, Y up, the body faces +Z, T-pose (arms
// along +-X, palms down, thumbs forward), subject's left = +X, pelvis joint near
// (0, -0.35, 0) (the origin lies in the lower chest, as in SMPL-X), about 1.7 m tall.
//
// The body is a set of 22 closed, outward-oriented genus-0 tube surfaces (torso, head,
// eyeballs, legs, feet, arms, palms, ten fingers with 3 joints each); parts overlap at
// the joints (about a fifth of the surface lies inside another part) and skinning
// blends smoothly across every joint (at most 4 influences per vertex).
// Shape columns 0..9 are derivatives (central differences) of the generator w.r.t. its
// proportions, per unit beta: 0 height (~7 cm), 1 girth, 2 leg length (trunk shorter),
// 3 shoulder width, 4 arm length, 5 head size, 6 belly, 7 hip width, 8 chest depth, 9 neck length;
// columns 10..299 are zero. Expression columns 0..9 move only the face: smile, mouth
// stretch, pucker, brows up, frown, cheek puff, upper lip up, lower lip down, squint,
// nose wrinkle; 10..99 are zero. Joints are ring averages of vertices (J_regressor),
// hence consistent with any shaped mesh. The UV atlas has one chart per part (seams
// duplicated), shelf-packed into [0,1]^2 without overlap, the head at ~1.8x texel density.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "body/body_model.h"

namespace haha {

enum class BodyResolution { low, full };

struct ProceduralBodyOptions {
  BodyResolution resolution = BodyResolution::full;  // full: 10,476 verts; low: ~1.9k
  uint64_t seed = 0;  // varies small proportions and details; same seed = same model
};

// One closed part of the procedural body: vertices [first_vert, first_vert + num_verts),
// faces [first_face, first_face + num_faces), UV vertices likewise.
struct ProceduralPart {
  std::string name;  // "torso", "head", "leg_l", "index_r", "eye_l", ...
  int first_vert = 0, num_verts = 0;
  int first_face = 0, num_faces = 0;
  int first_uv = 0, num_uv = 0;
};

struct ProceduralBodyInfo {
  std::vector<ProceduralPart> parts;
  int num_meaningful_shape = 0;  // shape columns 0..n-1 are non-zero, the rest zero
  int num_meaningful_expr = 0;   // expression columns 0..n-1 are non-zero
};

// "low" or "full" (throws haha::Error naming the value otherwise).
BodyResolution parse_body_resolution(const std::string& s);
const char* body_resolution_name(BodyResolution r);

// Deterministic for given options. `info` (optional) receives the part layout.
BodyModel make_procedural_body(const ProceduralBodyOptions& opt = {}, ProceduralBodyInfo* info = nullptr);

}  // namespace haha
