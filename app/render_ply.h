// `haha render-ply`: a standard 3DGS scene (io/ply_3dgs.h) rendered from one camera on the
// chosen device (the same rasterizer on the CPU and the GPU).
#pragma once

#include <vector>

#include "core/math.h"
#include "io/ply_3dgs.h"
#include "core/camera.h"
#include "train/device.h"

namespace haha {

// (H, W, 3) colour over `background`; `antialiased`: mip-splatting opacity compensation.
std::vector<float> render_ply_on(Device device, const GaussianPly& scene, const Camera& cam, Vec3f background,
                                 bool antialiased);

}  // namespace haha
