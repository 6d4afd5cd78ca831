// Which texels of a texture atlas are content: a texel belongs to face f's chart when its
// centre (render/texture.h conventions: texel (i, j) at u = (i + 1/2) / W,
// v = 1 - (j + 1/2) / H) lies inside f's UV triangle (edges included). Every other texel is
// gutter: only bilinear taps at a chart's border read it, so it is not content.
//
// Shared by the texture's speckle measure (render/texture_speckle.h) and the trainer's
// evidence-weighted smoothing and fill (train/texture_fill.h).
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"

namespace haha {

struct TextureCharts {
  int width = 0, height = 0;
  std::vector<int32_t> face;    // (height * width): the face whose UV triangle holds the texel centre, -1 = gutter
  std::vector<int32_t> island;  // (num_faces): UV island (faces joined through shared UV corners, ft)
  bool inside(int64_t texel) const { return face[size_t(texel)] >= 0; }
  int64_t count() const;        // texels inside charts
};

// Rasterizes the body's UV triangles (vt, ft) at texel centres. Where triangles overlap (a
// malformed UV map), the lower face index wins. Throws haha::Error "texture_charts: ..." for
// a non-positive size or a body without a UV map.
TextureCharts texture_charts(const BodyModel& body, int width, int height);

}  // namespace haha
