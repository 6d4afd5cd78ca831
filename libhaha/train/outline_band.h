// The band of pixels around a person's outline, where a matte's errors sit: a backdrop's
// colour baked into edge Gaussians, a silhouette that is too wide or too narrow. `haha eval`
// reports the PSNR inside it beside the whole-frame PSNR, which a thin fringe hardly moves.
#pragma once

#include <vector>

namespace haha {

// 1 for every pixel within `radius` pixels (Euclidean, between pixel centres) of the
// outline of `mask` > 0.5, else 0. The outline is every pixel whose 4-neighbour lies on the
// other side of the threshold (both sides count), so the band straddles the edge. A mask
// that is all person or all background has no outline: all zeros. mask: (H, W); radius >= 0.
std::vector<float> outline_band(const float* mask, int H, int W, int radius);

}  // namespace haha
