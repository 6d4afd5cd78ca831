// LBS forward and forward+backward for one frame of a full-resolution (10,475-vertex)
// SMPL-X-layout body, float, as the trainer runs it. Run on one core:
//   OMP_NUM_THREADS=1 ./bench_lbs
// Models (built here, no file needed): 300 + 100 shape columns (the real layout; 10 betas
// and 10 expression values used), up to 4 skinning influences per vertex, and
//   sparse: pose correctives only on the blocks of each vertex's joints (SMPL-X-like),
//   dense:  all 54 corrective blocks non-zero for every vertex (worst case, 61 MB),
// and the procedural full body of `haha synth-body` (make_procedural_body).
// Also the face-frame / posed-Gaussian transform, one Gaussian per face.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <vector>

#include "body/face_frames.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "support/body_synthetic_model.h"

namespace haha {
namespace {

// 0: synthetic, sparse posedirs; 1: synthetic, dense posedirs; 2: `haha synth-body` full.
const char* const kModelName[] = {"synthetic, sparse posedirs", "synthetic, dense posedirs", "procedural full body"};

const BodyModel& model(int which) {
  static std::unique_ptr<BodyModel> m[3];
  if (!m[which]) {
    if (which == 2) {
      m[which] = std::make_unique<BodyModel>(make_procedural_body());
    } else {
      test::SynthOptions o;
      o.total_verts = 10475;
      o.num_shape = 300;
      o.num_expr = 100;
      o.max_influences = 4;
      o.dense_posedirs = which == 1;
      m[which] = std::make_unique<BodyModel>(test::make_synthetic_model(o));
    }
  }
  return *m[which];
}

// Built once per model: Google Benchmark calls each function several times.
const Lbs<float>& lbs_of(int which) {
  static std::unique_ptr<Lbs<float>> l[3];
  if (!l[which]) l[which] = std::make_unique<Lbs<float>>(model(which));
  return *l[which];
}

// Average number of non-zero 27-value corrective blocks per vertex.
double blocks_per_vertex(const BodyModel& b) {
  if (b.posedirs.empty()) return 0;
  int64_t n = 0;
  for (int v = 0; v < b.num_verts; ++v)
    for (int f = 0; f < kNumJoints - 1; ++f) {
      bool nz = false;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 9; ++k) nz |= b.posedirs[(size_t(3) * v + c) * kNumPoseFeatures + 9 * f + k] != 0.0f;
      n += nz;
    }
  return double(n) / b.num_verts;
}

SmplxParams params() {
  SmplxParams p;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  for (auto& x : p.pose) x = u(rng);
  p.betas.resize(10);
  p.expression.resize(10);
  for (auto& x : p.betas) x = u(rng);
  for (auto& x : p.expression) x = u(rng);
  p.transl = {0.1f, 0.2f, 2.0f};
  return p;
}

void BM_LbsForward(benchmark::State& state) {
  const BodyModel& b = model(state.range(0));
  const Lbs<float>& lbs = lbs_of(state.range(0));
  const SmplxParams p = params();
  std::vector<float> verts(3 * size_t(b.num_verts)), joints(3 * kNumJoints);
  LbsCache<float> cache;
  for (auto _ : state) {
    lbs.forward(p, verts.data(), joints.data(), &cache);
    benchmark::DoNotOptimize(verts.data());
  }
  state.counters["verts"] = b.num_verts;
  state.counters["blocks/vert"] = blocks_per_vertex(b);
  state.SetLabel(kModelName[state.range(0)]);
}

void BM_LbsForwardBackward(benchmark::State& state) {
  const BodyModel& b = model(state.range(0));
  const Lbs<float>& lbs = lbs_of(state.range(0));
  const SmplxParams p = params();
  std::vector<float> verts(3 * size_t(b.num_verts)), joints(3 * kNumJoints);
  std::vector<float> dv(verts.size(), 0.01f), dj(joints.size(), 0.01f);
  LbsCache<float> cache;
  SmplxGrad<float> g = lbs.make_grad(p);
  for (auto _ : state) {
    lbs.forward(p, verts.data(), joints.data(), &cache);
    lbs.backward(p, cache, dv.data(), dj.data(), g);
    benchmark::DoNotOptimize(g.pose.data());
  }
  state.SetLabel(kModelName[state.range(0)]);
}

BENCHMARK(BM_LbsForward)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LbsForwardBackward)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

struct GaussianSetup {
  std::vector<float> verts;
  std::vector<int32_t> face;
  std::vector<float> offset, rotation, scale;
  GaussianLocalView<float> view() const {
    return {int(face.size()), face.data(), offset.data(), rotation.data(), scale.data()};
  }
};

const GaussianSetup& gaussians(const BodyModel& b) {
  static GaussianSetup s;
  if (!s.face.empty()) return s;
  s.verts.resize(3 * size_t(b.num_verts));
  lbs_of(0).forward(params(), s.verts.data(), nullptr, nullptr);
  for (int f = 0; f < b.num_faces; ++f) {
    s.face.push_back(f);
    s.offset.insert(s.offset.end(), {0.01f, 0.02f, 0.0f});
    s.rotation.insert(s.rotation.end(), {1, 0, 0, 0});
    s.scale.insert(s.scale.end(), {0.05f, 0.05f, 0.01f});
  }
  return s;
}

void BM_PoseGaussians(benchmark::State& state) {
  const BodyModel& b = model(0);
  const GaussianSetup& s = gaussians(b);
  const int n = int(s.face.size());
  std::vector<float> means(3 * n), quats(4 * n), scales(3 * n);
  for (auto _ : state) {
    pose_gaussians(s.verts.data(), b.faces.data(), b.num_faces, 0.05f, s.view(), means.data(), quats.data(),
                   scales.data());
    benchmark::DoNotOptimize(means.data());
  }
  state.counters["gaussians"] = n;
}

void BM_PoseGaussiansBackward(benchmark::State& state) {
  const BodyModel& b = model(0);
  const GaussianSetup& s = gaussians(b);
  const int n = int(s.face.size());
  std::vector<float> dm(3 * n, 0.01f), dq(4 * n, 0.01f), ds(3 * n, 0.01f);
  std::vector<float> dv(s.verts.size()), doff(3 * n), drot(4 * n), dsc(3 * n);
  for (auto _ : state) {
    pose_gaussians_backward(s.verts.data(), b.faces.data(), b.num_faces, 0.05f, s.view(), dm.data(), dq.data(),
                            ds.data(), dv.data(), doff.data(), drot.data(), dsc.data());
    benchmark::DoNotOptimize(dv.data());
  }
  state.counters["gaussians"] = n;
}

BENCHMARK(BM_PoseGaussians)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PoseGaussiansBackward)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace haha
