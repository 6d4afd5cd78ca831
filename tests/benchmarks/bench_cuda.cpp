// GPU speed of the CUDA backend: per-kernel times and the merged HAHA avatar render
// (mesh raster + texture, posed face-bound Gaussians occluded by the mesh depth, merge) of
// an avatar-like scene: the procedural SMPL-X-layout body at full resolution (10,476
// vertices), posed by LBS, with ~12k face-bound Gaussians and a 1024^2 texture, at
// 544 x 544 and 1024 x 1024. Times are GPU times (cudaEvent around each iteration; manual
// time in Google Benchmark); "FPS" = iterations / summed GPU time. Without a CUDA device
// every benchmark reports an error and skips.
//   cmake --build build --target bench_cuda && build/tests/bench_cuda
#include <benchmark/benchmark.h>

#include <cuda_runtime_api.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "cuda/avatar_render_cuda.h"
#include "cuda/face_frames_cuda.h"
#include "cuda/gaussian_raster_cuda.h"
#include "cuda/merge_cuda.h"
#include "train/losses_cuda.h"
#include "cuda/lbs_cuda.h"
#include "cuda/mesh_raster_cuda.h"
#include "train/optim_cuda.h"
#include "cuda/cuda_base.h"
#include "support/cuda_scene.h"
#include "train/knn.h"

using namespace haha;
using cuda::DeviceBuffer;

namespace {

constexpr int kGaussians = 12000;

bool skip_without_gpu(benchmark::State& state) {
  if (cuda::cuda_available()) return false;
  state.SkipWithError(cuda::device_description().c_str());
  return true;
}

// Times one iteration's GPU work between two events.
class GpuTimer {
 public:
  GpuTimer() {
    cuda::check(cudaEventCreate(&a_), "cudaEventCreate");
    cuda::check(cudaEventCreate(&b_), "cudaEventCreate");
  }
  ~GpuTimer() {
    cudaEventDestroy(a_);
    cudaEventDestroy(b_);
  }
  void start() { cuda::check(cudaEventRecord(a_), "cudaEventRecord"); }
  // Seconds since start(); waits for the work.
  double stop() {
    cuda::check(cudaEventRecord(b_), "cudaEventRecord");
    cuda::check(cudaEventSynchronize(b_), "cudaEventSynchronize");
    float ms = 0.0f;
    cuda::check(cudaEventElapsedTime(&ms, a_, b_), "cudaEventElapsedTime");
    return double(ms) * 1e-3;
  }

 private:
  cudaEvent_t a_{}, b_{};
};

// Runs `body` per iteration under the GPU timer and sets the FPS counter.
template <class F>
void timed_loop(benchmark::State& state, F&& body) {
  GpuTimer t;
  body();  // warm-up: allocations of the reused buffers happen here
  cuda::synchronize();
  double total = 0.0;
  for (auto _ : state) {
    t.start();
    body();
    const double s = t.stop();
    total += s;
    state.SetIterationTime(s);
  }
  if (total > 0) state.counters["FPS"] = double(state.iterations()) / total;
}

// The device copy of a scene at one resolution (built once per resolution).
struct GpuScene {
  testgpu::AvatarScene host;
  std::unique_ptr<cuda::AvatarBodyCuda> body;
  DeviceBuffer<float> verts, offset, rotation, scale, color, opacity, texture;
  DeviceBuffer<int32_t> face;
  GaussianSetView gaussians{};
  TextureView tex{};

  explicit GpuScene(int size) : host(testgpu::make_avatar_scene(BodyResolution::full, kGaussians, size, size, 1, 1024)) {
    body = std::make_unique<cuda::AvatarBodyCuda>(host.body);
    verts.upload(host.verts);
    offset.upload(host.offset);
    rotation.upload(host.rotation);
    scale.upload(host.scale);
    color.upload(host.color);
    opacity.upload(host.opacity);
    texture.upload(host.texture);
    face.upload(host.face);
    cuda::check_indices_cuda(face.data(), host.num_gaussians(), host.body.num_faces, "bench gaussians");
    gaussians = {host.num_gaussians(), face.data(), offset.data(), rotation.data(), scale.data(), color.data(),
                 opacity.data()};
    tex = {host.tex_w, host.tex_h, 3, texture.data()};
  }
  AvatarRenderRequest request(bool with_gaussians = true, bool with_mesh = true) const {
    AvatarRenderRequest r;
    r.camera = &host.cam;
    r.body = &body->topology;
    r.verts = verts.data();
    r.face_scale_divisor = host.divisor;
    r.gaussians = with_gaussians ? &gaussians : nullptr;
    r.texture = with_mesh ? &tex : nullptr;
    r.depth_margin = 0.005f;
    r.background[0] = r.background[1] = r.background[2] = 1.0f;
    return r;
  }
};

GpuScene& scene(int size) {
  static std::map<int, std::unique_ptr<GpuScene>> scenes;
  auto& s = scenes[size];
  if (!s) s = std::make_unique<GpuScene>(size);
  return *s;
}

// ---- merged render -----------------------------------------------------------------------

void BM_AvatarRender(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(int(state.range(0)));
  const auto req = s.request();
  cuda::AvatarRenderCudaBuffers buf;
  timed_loop(state, [&] { cuda::render_avatar_cuda(req, buf); });
  state.counters["pairs"] = double(buf.raster.num_pairs);
}
BENCHMARK(BM_AvatarRender)->Arg(544)->Arg(1024)->UseManualTime()->Unit(benchmark::kMicrosecond);

// The same with LBS in front (pose parameters -> image).
void BM_AvatarRenderWithLbs(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(int(state.range(0)));
  cuda::LbsCuda lbs(s.host.body);
  std::vector<float> pose(s.host.params.pose.begin(), s.host.params.pose.end());
  const SmplxView<float> p{pose.data(), s.host.params.betas.data(), int(s.host.params.betas.size()),
                           s.host.params.expression.data(), int(s.host.params.expression.size()),
                           s.host.params.transl.data()};
  DeviceBuffer<float> verts(s.host.verts.size());
  auto req = s.request();
  req.verts = verts.data();
  cuda::AvatarRenderCudaBuffers buf;
  timed_loop(state, [&] {
    lbs.forward(p, verts.data(), nullptr, nullptr);
    cuda::render_avatar_cuda(req, buf);
  });
}
BENCHMARK(BM_AvatarRenderWithLbs)->Arg(544)->Arg(1024)->UseManualTime()->Unit(benchmark::kMicrosecond);

// Forward + backward of the merged render to every input (a training step's render part).
void BM_AvatarRenderForwardBackward(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(int(state.range(0)));
  const auto req = s.request();
  const int P = s.host.cam.width * s.host.cam.height, V = s.host.body.num_verts, N = s.host.num_gaussians();
  DeviceBuffer<float> d_image(std::vector<float>(3 * size_t(P), 1e-3f));
  DeviceBuffer<float> gv(3 * size_t(V)), go(3 * size_t(N)), gr(4 * size_t(N)), gs(3 * size_t(N)), gc(3 * size_t(N)),
      gop(static_cast<size_t>(N)), gt(s.host.texture.size()), acc(static_cast<size_t>(N));
  AvatarRenderGrads grads{gv.data(), go.data(), gr.data(), gs.data(), gc.data(), gop.data(), gt.data(), acc.data()};
  cuda::AvatarRenderCudaBuffers buf;
  timed_loop(state, [&] {
    for (auto* b : {&gv, &go, &gr, &gs, &gc, &gop, &gt}) b->zero();
    cuda::render_avatar_cuda(req, buf);
    cuda::render_avatar_backward_cuda(req, buf, d_image.data(), nullptr, nullptr, grads);
  });
}
BENCHMARK(BM_AvatarRenderForwardBackward)->Arg(544)->Arg(1024)->UseManualTime()->Unit(benchmark::kMicrosecond);

// ---- per kernel ----------------------------------------------------------------------------

void BM_LbsForward(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(544);
  cuda::LbsCuda lbs(s.host.body);
  std::vector<float> pose(s.host.params.pose.begin(), s.host.params.pose.end());
  const SmplxView<float> p{pose.data(), s.host.params.betas.data(), 10, s.host.params.expression.data(), 10,
                           s.host.params.transl.data()};
  DeviceBuffer<float> verts(s.host.verts.size());
  cuda::LbsCudaCache cache;
  timed_loop(state, [&] { lbs.forward(p, verts.data(), nullptr, &cache); });
}
BENCHMARK(BM_LbsForward)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_LbsBackward(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(544);
  cuda::LbsCuda lbs(s.host.body);
  std::vector<float> pose(s.host.params.pose.begin(), s.host.params.pose.end());
  const SmplxView<float> p{pose.data(), s.host.params.betas.data(), 10, s.host.params.expression.data(), 10,
                           s.host.params.transl.data()};
  DeviceBuffer<float> verts(s.host.verts.size()), dv(std::vector<float>(s.host.verts.size(), 1e-3f));
  cuda::LbsCudaCache cache;
  lbs.forward(p, verts.data(), nullptr, &cache);
  Lbs<float> cpu(s.host.body);
  SmplxGrad<float> g = cpu.make_grad(s.host.params);
  timed_loop(state, [&] { lbs.backward(p, cache, dv.data(), nullptr, g); });
}
BENCHMARK(BM_LbsBackward)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_PoseGaussians(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(544);
  const int N = s.host.num_gaussians();
  const GaussianLocalView<float> l{N, s.face.data(), s.offset.data(), s.rotation.data(), s.scale.data()};
  DeviceBuffer<float> m(3 * size_t(N)), q(4 * size_t(N)), sc(3 * size_t(N));
  cuda::PoseGaussiansScratch scratch;
  const bool backward = state.range(0) != 0;
  DeviceBuffer<float> dm(std::vector<float>(3 * size_t(N), 1e-3f)), dq(std::vector<float>(4 * size_t(N), 1e-3f)),
      ds(std::vector<float>(3 * size_t(N), 1e-3f)), gv(s.host.verts.size()), go(3 * size_t(N)), gr(4 * size_t(N)),
      gs(3 * size_t(N));
  timed_loop(state, [&] {
    if (!backward)
      cuda::pose_gaussians_cuda(s.verts.data(), s.body->faces.data(), s.body->topology.num_faces, 1.0f, l, m.data(), q.data(),
                                sc.data(), scratch);
    else
      cuda::pose_gaussians_backward_cuda(s.verts.data(), s.body->faces.data(), s.body->topology.num_faces, 1.0f, l, dm.data(),
                                         dq.data(), ds.data(), gv.data(), go.data(), gr.data(), gs.data(), scratch);
  });
}
BENCHMARK(BM_PoseGaussians)->ArgName("backward")->Arg(0)->Arg(1)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_MeshRender(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(int(state.range(0)));
  MeshRenderInput in;
  in.verts = s.verts.data();
  in.num_verts = s.host.body.num_verts;
  in.faces = s.body->faces.data();
  in.num_faces = s.body->topology.num_faces;
  in.uv = s.body->uv.data();
  in.num_uv = s.body->topology.num_uv;
  in.uv_faces = s.body->uv_faces.data();
  in.texture = s.tex;
  cuda::MeshRenderCuda out;
  timed_loop(state, [&] { cuda::render_mesh_cuda(s.host.cam, in, out); });
}
BENCHMARK(BM_MeshRender)->Arg(544)->Arg(1024)->UseManualTime()->Unit(benchmark::kMicrosecond);

// Gaussian raster forward (+ backward) of the posed Gaussians occluded by the mesh depth.
void BM_GaussianRaster(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(int(state.range(0)));
  const bool backward = state.range(1) != 0;
  cuda::AvatarRenderCudaBuffers prep;
  cuda::render_avatar_cuda(s.request(), prep);  // posed Gaussians and the mesh depth
  const int P = s.host.cam.width * s.host.cam.height, N = s.host.num_gaussians();
  GaussianInputs<float> in;
  in.count = N;
  in.means = prep.means.data();
  in.quats = prep.quats.data();
  in.scales = prep.scales.data();
  in.opacities = s.opacity.data();
  in.colors = s.color.data();
  GaussianRasterSettings<float> st;
  st.depth_map = prep.mesh.depth;
  DeviceBuffer<float> color(3 * size_t(P)), alpha(static_cast<size_t>(P)), dcol(std::vector<float>(3 * size_t(P), 1e-3f)),
      dal(std::vector<float>(size_t(P), 1e-3f));
  DeviceBuffer<float> gm(3 * size_t(N)), gq(4 * size_t(N)), gs(3 * size_t(N)), go(static_cast<size_t>(N)), gc(3 * size_t(N));
  GaussianGrads<float> g;
  g.means = gm.data();
  g.quats = gq.data();
  g.scales = gs.data();
  g.opacities = go.data();
  g.colors = gc.data();
  cuda::GaussianRasterCudaState rs;
  timed_loop(state, [&] {
    cuda::rasterize_gaussians_cuda(in, s.host.cam, st, rs, {color.data(), alpha.data(), nullptr, nullptr});
    if (backward) cuda::rasterize_gaussians_backward_cuda(in, s.host.cam, st, rs, {dcol.data(), dal.data(), nullptr, nullptr}, g);
  });
  state.counters["pairs"] = double(rs.num_pairs);
}
BENCHMARK(BM_GaussianRaster)
    ->ArgNames({"size", "backward"})
    ->Args({544, 0})
    ->Args({544, 1})
    ->Args({1024, 0})
    ->Args({1024, 1})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

void BM_Merge(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(544);
  cuda::AvatarRenderCudaBuffers buf;
  const auto req = s.request();
  cuda::render_avatar_cuda(req, buf);
  const int P = s.host.cam.width * s.host.cam.height;
  MergeInputs m;
  m.num_pixels = P;
  m.color_front = buf.color_front.data();
  m.alpha = buf.alpha.data();
  m.mesh_color = buf.mesh.color;
  m.mesh_mask = buf.mesh.mask;
  DeviceBuffer<float> out(3 * size_t(P));
  timed_loop(state, [&] { cuda::merge_cuda(m, out.data()); });
}
BENCHMARK(BM_Merge)->UseManualTime()->Unit(benchmark::kMicrosecond);

// L2 + SSIM + edge losses with gradients at 544 x 544.
void BM_ImageLosses(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  const int H = 544, W = 544;
  const size_t P = size_t(H) * W;
  std::vector<float> a(3 * P), b(3 * P);
  for (size_t i = 0; i < a.size(); ++i) {
    a[i] = float(i % 251) / 251.0f;
    b[i] = float(i % 241) / 241.0f;
  }
  DeviceBuffer<float> x(a), y(b), g(3 * P);
  cuda::LossCudaScratch scratch;
  const int which = int(state.range(0));
  timed_loop(state, [&] {
    if (which == 0) cuda::l2_loss_cuda(x.data(), y.data(), H, W, scratch, nullptr, g.data(), 1.0f);
    if (which == 1) cuda::ssim_loss_cuda(x.data(), y.data(), H, W, scratch, nullptr, g.data(), 1.0f);
    if (which == 2) cuda::edge_loss_cuda(x.data(), y.data(), H, W, scratch, nullptr, g.data(), 1.0f);
  });
}
BENCHMARK(BM_ImageLosses)->ArgName("l2_ssim_edge")->Arg(0)->Arg(1)->Arg(2)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_AdamStep(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  const int64_t n = int64_t(kGaussians) * 14;  // offset, rotation, scale, colour, opacity
  DeviceBuffer<float> p(std::vector<float>(size_t(n), 0.1f)), g(std::vector<float>(size_t(n), 1e-3f));
  cuda::AdamCuda adam;
  adam.add_group("all", n, 1e-3);
  timed_loop(state, [&] { adam.step(0, p.data(), g.data()); });
}
BENCHMARK(BM_AdamStep)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_KnnReg(benchmark::State& state) {
  if (skip_without_gpu(state)) return;
  GpuScene& s = scene(544);
  cuda::AvatarRenderCudaBuffers buf;
  cuda::render_avatar_cuda(s.request(), buf);
  const int N = s.host.num_gaussians(), K = 3;
  const std::vector<float> means = buf.means.to_host();
  std::vector<int32_t> sets(size_t(N) * K);
  knn_sets(means.data(), N, K, sets.data());
  DeviceBuffer<int32_t> dsets(sets);
  DeviceBuffer<float> gp(3 * size_t(N)), gr(4 * size_t(N)), gsc(3 * size_t(N)), go(static_cast<size_t>(N)), gc(3 * size_t(N));
  const KnnRegInputs<float> in{N, buf.means.data(), s.rotation.data(), s.scale.data(), s.opacity.data(), s.color.data()};
  const KnnRegGrads<float> g{gp.data(), gr.data(), gsc.data(), go.data(), gc.data()};
  timed_loop(state, [&] { cuda::knn_reg_cuda(in, dsets.data(), K, {}, &g, 1.0f); });
}
BENCHMARK(BM_KnnReg)->UseManualTime()->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("cuda_device", cuda::device_description());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
