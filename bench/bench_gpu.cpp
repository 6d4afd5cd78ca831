// The bench's GPU timer (bench/bench_sweeps.h gpu_render_ms): the one piece of the bench
// that needs the CUDA backend, compiled to an error where the build has none.
#include <algorithm>
#include <chrono>
#include <vector>

#include "bench/bench_sweeps.h"
#include "core/error.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
#include "cuda/avatar_render_cuda.h"
#include "cuda/lbs_cuda.h"
#include "cuda/cuda_base.h"
#endif

namespace haha {

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
double gpu_render_ms(const Avatar& a, const Camera& cam, const SmplxParams& p, int repeats) {
  cuda::LbsCuda lbs(a.body);
  const cuda::AvatarBodyCuda body(a.body);
  cuda::DeviceBuffer<float> verts(size_t(a.body.num_verts) * 3);
  const BoundGaussians& g = a.gaussians;
  const cuda::DeviceBuffer<int32_t> face(g.face);
  const cuda::DeviceBuffer<float> off(g.offset), rot(g.rotation), sc(g.scale), col(g.color), op(g.opacity),
      tex(a.texture.rgb), cov(a.mesh_coverage);
  const GaussianSetView gv{g.size(), face.data(), off.data(), rot.data(), sc.data(), col.data(), op.data()};
  const TextureView tv{a.texture.width, a.texture.height, 3, tex.data()};
  AvatarRenderRequest req;
  req.camera = &cam;
  req.body = &body.topology;
  req.verts = verts.data();
  req.face_scale_divisor = a.face_scale_divisor;
  req.gaussians = g.size() > 0 ? &gv : nullptr;
  req.texture = &tv;
  req.mesh_coverage = a.mesh_coverage.empty() ? nullptr : cov.data();
  req.depth_margin = a.depth_margin;
  cuda::AvatarRenderCudaBuffers buf;
  const SmplxView<float> v{p.pose.data(), p.betas.data(), int(p.betas.size()), p.expression.data(),
                           int(p.expression.size()), p.transl.data()};
  auto once = [&] {
    const auto t0 = std::chrono::steady_clock::now();
    lbs.forward(v, verts.data(), nullptr, nullptr);
    cuda::render_avatar_cuda(req, buf);
    cuda::synchronize("bench render");
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  once();
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) t.push_back(once());
  std::sort(t.begin(), t.end());
  return t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
}
#else
double gpu_render_ms(const Avatar&, const Camera&, const SmplxParams&, int) {
  fail("bench", "GPU timings need a build with the CUDA backend");
}
#endif

}  // namespace haha
