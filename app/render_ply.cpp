#include "app/render_ply.h"

#include "core/error.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
#include "cuda/gaussian_raster_cuda.h"
#endif

namespace haha {

std::vector<float> render_ply_on(Device device, const GaussianPly& scene, const Camera& cam, Vec3f background,
                                 bool antialiased) {
  if (device == Device::cpu) return render_ply_image(scene, cam, background, antialiased);
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
  const ActivatedPly a = activate(scene);
  return cuda::render_gaussians_image_cuda(a.inputs(scene), cam, background, antialiased);
#else
  fail("--device", "cuda requested but this build has no CUDA backend");
#endif
}

}  // namespace haha
