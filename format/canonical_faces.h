// The canonical face order of a triangle mesh (format/spec.md, gaussians.faceOrder): every
// face rotated to the lexicographically smallest of its three corner rotations (orientation
// kept), the faces sorted by that triple. It depends only on which body vertices each face
// joins, so Gaussians bound to canonical faces survive any tool that reorders the mesh's
// vertices or faces or rotates a face's corners (Draco's edgebreaker, glTF-Transform).
#pragma once

#include <cstdint>
#include <vector>

namespace haha {

struct CanonicalFaces {
  std::vector<int32_t> order;     // (F) canonical face c is input face order[c]
  std::vector<uint8_t> rotation;  // (F) per input face: its canonical corner 0 is input corner rotation[f]
};

// `faces`: (F, 3) vertex indices. Faces with equal triples (the same triangle) keep their
// input order among themselves.
CanonicalFaces canonical_faces(const int32_t* faces, int num_faces);

}  // namespace haha
