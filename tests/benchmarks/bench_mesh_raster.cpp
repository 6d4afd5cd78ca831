// Mesh rasterization speed: the procedural SMPL-X-layout body (body/procedural_body.h,
// 20,864 triangles, rest T-pose, 1.7 m tall, 1.8 m wide, about 440 px across) at 512 x 512,
// its UV atlas (seams) and a 512 x 512 texture; 2 threads (and 1 for comparison).
//   cmake --build build --target bench_mesh_raster && build/tests/bench_mesh_raster
// Target: rasterization <= 10 ms on 2 cores.
#include <benchmark/benchmark.h>

#include <cmath>

#include "core/parallel.h"
#include "body/procedural_body.h"
#include "support/render_mesh_fixtures.h"
#include "render/render_mesh.h"

using namespace haha;

namespace {

struct BenchScene {
  fixtures::TestMesh mesh;
  Camera cam = fixtures::look_at_camera(512, 512, 790, Vec3d(0.6, -0.2, 3.3), Vec3d(0, -0.43, 0));
  std::vector<float> texture;
  MeshRenderInput in;
  BenchScene() {
    const BodyModel body = make_procedural_body();
    mesh.verts = body.v_template;
    mesh.faces = body.faces;
    mesh.uv = body.vt;
    mesh.ft = body.ft;
    texture.resize(512 * 512 * 3);
    for (size_t i = 0; i < texture.size(); ++i) texture[i] = float((i * 2654435761u) % 1000) / 1000.0f;
    in.verts = mesh.verts.data();
    in.num_verts = mesh.num_verts();
    in.faces = mesh.faces.data();
    in.num_faces = mesh.num_faces();
    in.uv = mesh.uv.data();
    in.num_uv = mesh.num_uv();
    in.uv_faces = mesh.ft.data();
    in.texture = TextureView{512, 512, 3, texture.data()};
  }
};

const BenchScene& scene() {
  static const BenchScene s;
  return s;
}

void set_counters(benchmark::State& state, const MeshRaster& r) {
  int covered = 0;
  for (int32_t t : r.tri) covered += t >= 0;
  state.counters["triangles"] = scene().mesh.num_faces();
  state.counters["covered_px"] = covered;
  state.counters["threads"] = num_threads();
}

void BM_MeshRasterForward(benchmark::State& state) {
  set_num_threads(int(state.range(0)));
  const BenchScene& s = scene();
  MeshRaster r;
  for (auto _ : state) {
    rasterize_mesh(s.cam, MeshView{s.mesh.verts.data(), s.mesh.num_verts(), s.mesh.faces.data(), s.mesh.num_faces()}, r);
    benchmark::DoNotOptimize(r.tri.data());
  }
  set_counters(state, r);
}

// UV interpolation + bilinear texture sampling over the raster (the texture pass of M).
void BM_MeshTextureSample(benchmark::State& state) {
  set_num_threads(int(state.range(0)));
  const BenchScene& s = scene();
  MeshRender r;
  render_mesh(s.cam, s.in, r);
  const int P = r.raster.num_pixels();
  for (auto _ : state) {
    interpolate(P, r.raster.tri.data(), r.raster.bary.data(), s.in.uv_faces, s.in.uv, 2, r.uv.data());
    sample_texture(s.in.texture, P, r.raster.tri.data(), r.uv.data(), r.color.data());
    benchmark::DoNotOptimize(r.color.data());
  }
  set_counters(state, r.raster);
}

void BM_RenderMeshForward(benchmark::State& state) {
  set_num_threads(int(state.range(0)));
  const BenchScene& s = scene();
  MeshRender r;
  for (auto _ : state) {
    render_mesh(s.cam, s.in, r);
    benchmark::DoNotOptimize(r.color.data());
  }
  set_counters(state, r.raster);
}

// Backward to the texture and the vertices (dL/dM and dL/dD given).
void BM_RenderMeshBackward(benchmark::State& state) {
  set_num_threads(int(state.range(0)));
  const BenchScene& s = scene();
  MeshRender r;
  render_mesh(s.cam, s.in, r);
  const int P = r.raster.num_pixels();
  std::vector<float> gM(size_t(P) * 3, 0.1f), gD(P, 0.01f);
  std::vector<float> gtex(s.texture.size()), gv(s.mesh.verts.size());
  for (auto _ : state) {
    std::fill(gtex.begin(), gtex.end(), 0.0f);
    std::fill(gv.begin(), gv.end(), 0.0f);
    render_mesh_backward(s.cam, s.in, r, gM.data(), gD.data(), gtex.data(), gv.data());
    benchmark::DoNotOptimize(gv.data());
  }
  set_counters(state, r.raster);
}

}  // namespace

BENCHMARK(BM_MeshRasterForward)->Arg(2)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MeshTextureSample)->Arg(2)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderMeshForward)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderMeshBackward)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
