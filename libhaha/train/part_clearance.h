// The clothed surface must not grow one body part over another. Fitted to the masks of a
// side view, the torso would grow out over the arm held against it (the mask there is arm
// and torso alike), and its surface would then sit in front of the arm: the merge's depth
// test hides the arm's Gaussians behind it. Hands on the hips and arms against a dress are
// the same case.
//
// The bound: in every frame, a vertex v moved by h u (u its posed normal direction,
// train/surface_fit.h) stays on its own side of the perpendicular bisector plane between v
// and each vertex w of another part:
//     |h u| <= |v + h u - w|   <=>   h <= |d|^2 / (2 d.u),   d = w - v, for d.u > 0,
// so both sides of a gap may grow at once and never cross, and a vertex facing away from
// the other part (d.u <= 0) is not held. Parts: the trunk (pelvis, spine, collars, neck,
// head, face), each arm from the shoulder joint with its hand, each leg from the hip joint
// with its foot; a vertex belongs to the part carrying most of its skinning weight. A
// garment appended to the body (body/garment.h) is a part of its own that nothing holds: it
// wraps the trunk and the legs by design, and held off the arms as well (tried) a flared
// skirt stayed narrower than it is where the hands swing beside it (the demo subject: the
// textured mesh 0.29 dB lower, 283 of its 672 vertices held; docs/results.md, "What the
// merge costs on real footage").
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"

namespace haha {

enum class BodyPart : int8_t { Trunk = 0, LeftArm, RightArm, LeftLeg, RightLeg, Garment };

// The part of each vertex (num_verts).
std::vector<BodyPart> body_part_of_vertices(const BodyModel& body);

// Whether the surfaces of parts a and b must stay apart (different parts of the body; a
// garment with nothing).
bool parts_kept_apart(BodyPart a, BodyPart b);

// Per body vertex (num_body_verts) the largest outward h that keeps the bisector rule above
// in every frame: posed[f] and dirs[f] are frame f's posed vertices and posed normal
// directions (num_verts x 3 each). At most `cap` (a vertex no other part comes near gets
// it), at least 0.
std::vector<float> part_clearance_bounds(const BodyModel& body, const std::vector<std::vector<float>>& posed,
                                         const std::vector<std::vector<float>>& dirs, float cap);

}  // namespace haha
