// After stage 2: texels the video barely saw take their colour from the seen ones around
// them on the body's surface, and the charts' borders are dilated into the gutter.
//
//  1. Texel graph: chart texels (render/texture_charts.h) linked to their 4 grid neighbours
//     of the same UV island, plus seam links: along every mesh edge whose two faces use
//     different UV corners, the texels nearest to the same points of the edge on both sides
//     are linked (so a chart's colour flows across the seam, as over the surface).
//  2. Confidence c = min(1, evidence / evidence_full) (train/texture_evidence.h).
//  3. Fill x: minimiser of sum_i 4 c_i |x_i - t_i|^2 + sum_links |x_i - x_j|^2 by
//     Gauss-Seidel sweeps, started from a breadth-first spread of the texels with c >= 1/2
//     (so even a chart nobody saw starts from its nearest seen neighbours' colour).
//  4. Chart texels become c t + (1 - c) x: well-seen texels keep their detail exactly.
//  5. Gutter texels take the mean of their already-filled 4-neighbours ring by ring outward
//     (a mipmapped engine samples no background at chart borders), blended by their own
//     evidence the same way (bilinear taps at chart borders trained some of them).
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"
#include "render/texture_charts.h"

namespace haha {

struct TexelGraph {
  std::vector<int64_t> offset;    // (N + 1) CSR over texels (height * width); gutter texels have none
  std::vector<int64_t> neighbor;  // texel indices
  int64_t seam_links = 0;         // undirected links across UV seams
};

// Throws haha::Error "texel_graph: ..." when the charts do not match the body's faces.
TexelGraph texel_graph(const BodyModel& body, const TextureCharts& charts);

struct FillOptions {
  double evidence_full = 1.0;  // evidence at which a texel is kept as trained (> 0)
  int iterations = 300;        // Gauss-Seidel sweeps
};

struct FillReport {
  int64_t chart_texels = 0, low_texels = 0;  // low: evidence below evidence_full
  int64_t unseen_texels = 0;                 // evidence 0
  int64_t seam_links = 0;
};

// Fills rgb (height, width, 3) in place as above. evidence has height * width values.
// Throws haha::Error "texture_fill: ..." on mismatched sizes or a non-positive evidence_full.
FillReport fill_low_evidence(const BodyModel& body, const TextureCharts& charts, const std::vector<float>& evidence,
                             const FillOptions& opt, std::vector<float>& rgb);

// Step 5 alone: gutter texels from their chart neighbours outward; confidence (height * width,
// 0..1, may be empty = 0) blends as above.
void dilate_into_gutter(const TextureCharts& charts, const std::vector<float>& confidence, std::vector<float>& rgb);

}  // namespace haha
