// Consistency checks of an Avatar (sizes, index ranges, finite values). Used by pack,
// unpack and the run-directory reader, so every path reports bad data the same way:
// one haha::Error "<where>: <array>: <problem>".
#pragma once

#include <string>

#include "body/avatar.h"

namespace haha {

// Body arrays: sizes against num_verts / num_faces, faces and ft in range, 55 parents
// with parents[0] = -1 and parents[j] < j, finite values, non-negative skinning weights.
void validate_body(const BodyModel& b, const std::string& where);

// Gaussians: consistent array sizes, face in [0, num_faces) (num_faces < 0: unchecked),
// finite values, scale > 0, opacity in [0, 1], rotation not (near) zero.
void validate_gaussians(const BoundGaussians& g, int num_faces, const std::string& where);

// Texture size and finite values; betas, expression finite; face_scale_divisor > 0;
// mesh_coverage in [0, 1] (its size is checked against the body by validate_avatar).
void validate_subject(const Avatar& a, const std::string& where);

// Whether the body still has shape/expression blend shapes to apply (some non-zero
// shapedirs column). False for an unpacked (baked) body, also after a save/load through
// the SMPL-X .npz layout, which pads shapedirs with zero columns.
bool has_shape_blend(const BodyModel& b);

// All of the above.
void validate_avatar(const Avatar& a, const std::string& where);

}  // namespace haha
