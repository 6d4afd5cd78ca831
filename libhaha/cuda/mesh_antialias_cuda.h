// The silhouette antialiasing pass (render/mesh_antialias.h) on the GPU: the same per-pixel
// kernels, one thread a pixel; gradients scatter with atomics. Buffer contracts are the CPU
// functions', with device pointers in the inputs.
#pragma once

#include "render/mesh_antialias.h"

namespace haha::cuda {

// color_out (P, C) and mask_out (P) are OVERWRITTEN.
void antialias_cuda(const AntialiasInputsT<float>& in, float* color_out, float* mask_out);

// grad_color (P, C) and grad_verts (V, 3) are ACCUMULATED (either may be null);
// grad_mask_out may be null (no coverage gradient).
void antialias_backward_cuda(const AntialiasInputsT<float>& in, const float* grad_color_out,
                             const float* grad_mask_out, float* grad_color, float* grad_verts);

}  // namespace haha::cuda
