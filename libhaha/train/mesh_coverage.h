// The mesh's coverage, learned from the training mattes (Avatar::mesh_coverage): where an
// estimated surface overshoots the person (a clothed surface grown past the outline, a fit
// a little off), the textured mesh would paint its colour over background and hide the
// Gaussians that follow the matte; the merge then cuts the mesh there (render/mesh_raster.h,
// the coverage cut) and shows what lies behind it.
//
// Every training frame votes: each pixel the uncut mesh covers adds its matte value to the
// three corners of its visible face, weighted by their barycentric weights, so a vertex's
// coverage is the matte's mean over the pixels its neighbourhood drew (the pixel count
// weights the views: a part seen squarely in many frames outvotes a grazing rim). A vertex
// no frame drew keeps 1 (nothing says it is not the person), and so does a vertex with too
// little weight to judge (under `min_weight` pixels).
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera.h"

namespace haha {

// Barycentric weight (about pixels) under which a vertex is not judged: the trainer's min_weight.
inline constexpr double kMinCoverageWeight = 2.0;

// One frame's vote: the posed body (V, 3) in its camera, the matte (P) in [0, 1].
struct CoverageFrame {
  const Camera* camera = nullptr;
  const float* verts = nullptr;
  const float* matte = nullptr;
};

struct CoverageReport {
  int vertices = 0;        // V
  int cut_vertices = 0;    // coverage < kCoverageCutoff
  int unjudged = 0;        // under min_weight: kept at 1
};

// Coverage (V) in [0, 1]. faces (F, 3) index the V vertices. Throws haha::Error for a frame
// without camera, vertices or matte.
std::vector<float> learn_mesh_coverage(int num_verts, const int32_t* faces, int num_faces,
                                       const std::vector<CoverageFrame>& frames, double min_weight,
                                       CoverageReport* report = nullptr);

}  // namespace haha
