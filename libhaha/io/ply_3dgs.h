// Standard 3DGS scene files (.ply as written by the reference 3DGS trainer and most tools):
// one `vertex` element with float properties
//   x, y, z                 centre (world)
//   nx, ny, nz              optional, ignored by rendering
//   f_dc_0..2               SH degree-0 coefficient per channel
//   f_rest_0..M-1           higher SH coefficients, channel-major: f_rest[c * (K-1) + k-1] is
//                           coefficient k (1..K-1) of channel c; M = 3 (K - 1) in {0, 9, 24, 45}
//   opacity                 logit
//   scale_0..2              log of the standard deviations
//   rot_0..3                quaternion (w, x, y, z), not necessarily unit
// Formats: binary_little_endian, binary_big_endian, ascii. Property types: any PLY scalar
// (converted to float). Other properties of the vertex element are ignored; `vertex` must be
// the first element (elements after it are ignored). Any problem (not a PLY, missing
// property, list property in vertex, truncated data, bad number, NaN/Inf) is a haha::Error
// "<path>: <problem>".
#pragma once

#include <string>
#include <vector>

#include "render/gaussian_raster.h"

namespace haha {

struct GaussianPly {
  int sh_degree = 0;
  std::vector<float> means;          // (N, 3)
  std::vector<float> normals;        // (N, 3), empty when the file has none
  std::vector<float> sh;             // (N, (deg+1)^2, 3) coefficient-major (render/sh.h)
  std::vector<float> opacity_logit;  // (N)
  std::vector<float> log_scales;     // (N, 3)
  std::vector<float> quats;          // (N, 4) (w, x, y, z) as stored
  int size() const { return int(opacity_logit.size()); }
};

GaussianPly read_ply_3dgs(const std::string& path);

// Writes binary little-endian (or ascii) with nx, ny, nz (zeros when `normals` is empty),
// atomically. Throws haha::Error naming the path when the arrays' sizes disagree.
void write_ply_3dgs(const std::string& path, const GaussianPly& g, bool ascii = false);

// The rasterizer's view of a loaded scene: activations applied once here
// (opacity = sigmoid(logit), scale = exp(log_scale)); SH colours as in 3DGS.
struct ActivatedPly {
  std::vector<float> opacities, scales;
  GaussianInputs<float> inputs(const GaussianPly& g) const;  // views into g and *this
};
ActivatedPly activate(const GaussianPly& g);

// What `haha render-ply` draws: the scene's SH colours (as 3DGS: max(0, SH + 0.5)), plain
// 3DGS splatting (antialiased = false unless asked), composited over a constant background.
// Returns (H, W, 3) float, row-major, top row first. 3DGS culls centres closer than 0.2; set
// the camera's near plane to 0.2 for an exact match of that rule.
std::vector<float> render_ply_image(const GaussianPly& g, const Camera& cam, Vec3f background,
                                    bool antialiased = false);

}  // namespace haha
