// How much the training frames saw each texel: the sum over frames and pixels of the
// bilinear weights the texture's backward scatters to it (render/texture.h), each pixel
// weighted by its mask value and by |cos| of the angle between its face's normal and the
// view ray (a surface seen edge-on smears one pixel over many texels). Units: pixels seen
// squarely; a texel of evidence 1 was covered by about one full frontal pixel in all.
// The trainer sums it over every training frame once (the same taps as one epoch of the
// stage-2 draws), at the texture's size; it decides how far each texel is smoothed and
// filled from its neighbours (train/texture_fill.h).
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera.h"
#include "render/texture_charts.h"

namespace haha {

// ACCUMULATES one frame into evidence (tex_height * tex_width). tri (P) and uv (2P) are the
// mesh raster of the posed body (render/mesh_raster.h, interpolate with ft/vt); faces (F, 3)
// index posed_verts (V, 3); mask (P) may be null (weight 1). P = cam.width * cam.height.
void accumulate_texture_evidence(const Camera& cam, const float* posed_verts, const int32_t* faces,
                                 const int32_t* tri, const float* uv, const float* mask, int tex_width,
                                 int tex_height, float* evidence);

// The share (0..1) of chart texels whose evidence is below `threshold` (0 without charts).
double evidence_share_below(const std::vector<float>& evidence, const TextureCharts& charts, double threshold);

}  // namespace haha
