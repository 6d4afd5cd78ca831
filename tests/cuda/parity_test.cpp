// CPU vs CUDA parity of every CUDA launcher, forward and gradients, on the same inputs
// (label gpu). Without a usable CUDA device the parity tests GTEST_SKIP(); the device
// plumbing tests (Device parsing, error reporting) run everywhere.
//
// Tolerances (err = |gpu - cpu| / (|cpu| + 1e-3 max|cpu|), per array):
//   kFwd  = 1e-5  forward values of per-element kernels (the same HAHA_HD code; nvcc fuses
//                 multiply-adds, g++ -O2 on x86-64 does not, so last bits differ);
//   kGrad = 1e-4  gradients and other sums built with atomics (order-dependent in float);
//   kLoss = 1e-5  loss values (summed in double on both sides).
// Outputs decided by a hard cut (alpha >= 1/255, transmittance >= 1e-4, pixel coverage
// by the edge functions) can flip where the cut's argument lies within rounding of the
// threshold; those comparisons allow a stated small fraction of elements beyond the
// tolerance (kCutFrac), everything else must pass everywhere. Arrays with elements that
// rounding alone moves past kFwd (cancelling sums, thin triangles; first run on an H100)
// are also held to a float64 evaluation of the same code: the GPU as accurate as the CPU
// (expect_as_accurate).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "body/face_frames.h"
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
#include "render/gaussian_raster.h"
#include "render/merge.h"
#include "render/mesh_antialias.h"
#include "render/mesh_raster.h"
#include "render/render_mesh.h"
#include "render/texture.h"
#include "train/adam.h"
#include "render/avatar_render.h"
#include "train/knn.h"
#include "train/losses.h"

namespace haha {
namespace {

using cuda::DeviceBuffer;

constexpr double kFwd = 1e-5;
constexpr double kGrad = 1e-4;
constexpr double kLoss = 1e-5;
constexpr double kCutFrac = 2e-3;  // fraction of elements allowed past a hard cut

#define REQUIRE_CUDA()                                                                \
  do {                                                                                \
    if (!cuda::cuda_available()) GTEST_SKIP() << cuda::device_description();          \
  } while (0)

template <class T>
DeviceBuffer<T> up(const std::vector<T>& v) {
  return DeviceBuffer<T>(v);
}

std::vector<float> randv(size_t n, float lo, float hi, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> U(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = U(rng);
  return v;
}

// Compares gpu against cpu; returns the number of elements beyond `tol`.
int64_t count_beyond(const std::vector<float>& cpu, const std::vector<float>& gpu, double tol, double* max_err) {
  double amax = 0.0;
  for (float c : cpu)
    if (std::isfinite(c)) amax = std::max(amax, double(std::fabs(c)));
  const double floor = 1e-3 * amax + 1e-30;
  int64_t bad = 0;
  *max_err = 0.0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    const double c = cpu[i], g = gpu[i];
    if (c == g) continue;  // also equal infinities
    double err = std::fabs(g - c) / (std::fabs(c) + floor);
    if (!std::isfinite(err)) err = std::numeric_limits<double>::infinity();
    *max_err = std::max(*max_err, err);
    bad += err > tol;
  }
  return bad;
}

void expect_close(const std::string& what, const std::vector<float>& cpu, const std::vector<float>& gpu, double tol,
                  double allowed_frac = 0.0) {
  ASSERT_EQ(cpu.size(), gpu.size()) << what;
  double max_err = 0.0;
  const int64_t bad = count_beyond(cpu, gpu, tol, &max_err);
  const auto allowed = int64_t(allowed_frac * double(cpu.size()));
  EXPECT_LE(bad, allowed) << what << ": " << bad << " of " << cpu.size() << " values beyond " << tol
                          << " (max error " << max_err << ")";
}

// Arrays whose elements are sums of cancelling terms (vertex positions through the joint
// chain, quaternion components near zero, gradients through thin triangles) can
// differ beyond the per-element tolerance by rounding alone: nvcc contracts multiply-adds
// and g++ does not. Such arrays are judged against a float64 evaluation of the same code:
// the GPU must be as accurate as the CPU (RMS error at most 2x, largest error at most 4x
// the CPU's, each plus 4 float epsilons of the reference's RMS / largest magnitude), and
// all but kRoundFrac of the elements must still meet the per-element tolerance.
constexpr double kRoundFrac = 5e-2;

template <class R>
void expect_as_accurate(const std::string& what, const std::vector<R>& ref, const std::vector<float>& cpu,
                        const std::vector<float>& gpu, double tol) {
  ASSERT_EQ(ref.size(), cpu.size()) << what;
  ASSERT_EQ(ref.size(), gpu.size()) << what;
  double sc = 0, sg = 0, sr = 0, mc = 0, mg = 0, mr = 0;
  int64_t inf_differ = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    const double r = double(ref[i]);
    if (!std::isfinite(r)) {  // e.g. the depth of an uncovered pixel: all three the same
      inf_differ += !(double(cpu[i]) == r && double(gpu[i]) == r);
      continue;
    }
    const double ec = std::fabs(cpu[i] - r), eg = std::fabs(gpu[i] - r);
    sc += ec * ec, sg += eg * eg, sr += r * r;
    mc = std::max(mc, ec), mg = std::max(mg, eg), mr = std::max(mr, std::fabs(r));
  }
  const double n = double(std::max<size_t>(ref.size(), 1)), eps = std::numeric_limits<float>::epsilon();
  const double rc = std::sqrt(sc / n), rg = std::sqrt(sg / n), rr = std::sqrt(sr / n);
  const std::string stats = what + " vs float64: rms error cpu " + std::to_string(rc) + " gpu " + std::to_string(rg) +
                            ", largest cpu " + std::to_string(mc) + " gpu " + std::to_string(mg);
  EXPECT_EQ(inf_differ, 0) << what << ": non-finite reference values not matched";
  EXPECT_TRUE(std::isfinite(rg) && rg <= 2 * rc + 4 * eps * rr) << stats;
  EXPECT_TRUE(std::isfinite(mg) && mg <= 4 * mc + 4 * eps * mr) << stats;
  expect_close(what, cpu, gpu, tol, kRoundFrac);
}

template <class T>
std::vector<double> to_double(const std::vector<T>& v) {
  return std::vector<double>(v.begin(), v.end());
}

void expect_close_scalar(const std::string& what, double cpu, double gpu, double tol) {
  EXPECT_LE(std::fabs(gpu - cpu), tol * (std::fabs(cpu) + 1e-12)) << what << ": cpu " << cpu << " gpu " << gpu;
}

// ------------------------------------------------------------------ plumbing (no GPU needed)

TEST(CudaPlumbing, ErrorsBecomeHahaErrors) {
  try {
    cuda::check(cudaErrorInvalidValue, "probe");
    FAIL() << "no throw";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("cuda: probe: cudaErrorInvalidValue", 0), 0u) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  EXPECT_NO_THROW(cuda::check(cudaSuccess, "fine"));
  EXPECT_FALSE(cuda::device_description().empty());
  if (!cuda::cuda_available()) {
    // Allocation without a device is a clean haha::Error, not a crash.
    EXPECT_THROW(DeviceBuffer<float>(16), Error);
  }
}

TEST(CudaPlumbing, DeviceBufferRoundTrip) {
  REQUIRE_CUDA();
  const std::vector<float> v = randv(1000, -1, 1, 3);
  DeviceBuffer<float> b(v);
  EXPECT_EQ(b.size(), v.size());
  EXPECT_EQ(b.to_host(), v);
  DeviceBuffer<float> moved = std::move(b);
  EXPECT_EQ(b.data(), nullptr);
  EXPECT_EQ(moved.to_host(), v);
  moved.assign_zero(10);
  EXPECT_EQ(moved.to_host(), std::vector<float>(10, 0.0f));
  EXPECT_THROW(moved.download(nullptr, 11), Error);
}

// ------------------------------------------------------------------ LBS

TEST(CudaParity, LbsForwardBackward) {
  REQUIRE_CUDA();
  const BodyModel body = make_procedural_body({BodyResolution::low, 4});
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> U(-0.4f, 0.4f);
  SmplxParams p;
  for (float& v : p.pose) v = U(rng);
  p.betas.assign(10, 0.0f);
  for (float& v : p.betas) v = 2 * U(rng);
  p.expression.assign(10, 0.0f);
  for (float& v : p.expression) v = 2 * U(rng);
  p.transl = {0.1f, -0.2f, 0.3f};
  const int V = body.num_verts;

  Lbs<float> cpu(body);
  std::vector<float> vc(3 * size_t(V)), jc(3 * kNumJoints);
  LbsCache<float> cc;
  cpu.forward(p, vc.data(), jc.data(), &cc);

  cuda::LbsCuda gpu(body);
  DeviceBuffer<float> vg(3 * size_t(V));
  std::vector<float> jg(3 * kNumJoints);
  cuda::LbsCudaCache gc;
  std::vector<float> pose(p.pose.begin(), p.pose.end());
  const SmplxView<float> view{pose.data(), p.betas.data(), 10, p.expression.data(), 10, p.transl.data()};
  gpu.forward(view, vg.data(), jg.data(), &gc);
  Lbs<double> ref(body);
  std::vector<double> vr(3 * size_t(V));
  ref.forward(p, vr.data(), nullptr, nullptr);
  expect_as_accurate("lbs verts", vr, vc, vg.to_host(), kFwd);
  EXPECT_EQ(jc, jg);  // the joint chain runs on the host in both

  const std::vector<float> dv = randv(3 * size_t(V), -1, 1, 11), dj = randv(3 * kNumJoints, -1, 1, 12);
  SmplxGrad<float> gcpu = cpu.make_grad(p), ggpu = cpu.make_grad(p);
  cpu.backward(p, cc, dv.data(), dj.data(), gcpu);
  DeviceBuffer<float> dvg = up(dv);
  gpu.backward(view, gc, dvg.data(), dj.data(), ggpu);
  expect_close("lbs d_pose", std::vector<float>(gcpu.pose.begin(), gcpu.pose.end()),
               std::vector<float>(ggpu.pose.begin(), ggpu.pose.end()), kGrad);
  expect_close("lbs d_betas", gcpu.betas, ggpu.betas, kGrad);
  expect_close("lbs d_expression", gcpu.expression, ggpu.expression, kGrad);
  expect_close("lbs d_transl", std::vector<float>(gcpu.transl.begin(), gcpu.transl.end()),
               std::vector<float>(ggpu.transl.begin(), ggpu.transl.end()), kGrad);
}

// ------------------------------------------------------------------ face frames, posed Gaussians

template <class T>
std::vector<T> frames_as_floats(const std::vector<FaceFrame<T>>& f) {
  std::vector<T> out;
  for (const auto& x : f) {
    for (int k = 0; k < 3; ++k) out.push_back(x.t[k]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out.push_back(x.R.a[r][c]);
    out.insert(out.end(), {x.q.w, x.q.x, x.q.y, x.q.z, x.k});
  }
  return out;
}

TEST(CudaParity, FaceFramesAndPoseGaussians) {
  REQUIRE_CUDA();
  const testgpu::AvatarScene s = testgpu::make_avatar_scene(BodyResolution::low, 5000, 64, 64, 5, 8);
  const int F = s.body.num_faces, V = s.body.num_verts, N = s.num_gaussians();
  const float div = 0.7f;
  DeviceBuffer<float> verts = up(s.verts);
  DeviceBuffer<int32_t> faces = up(s.body.faces);

  std::vector<FaceFrame<float>> fc(static_cast<size_t>(F));
  compute_face_frames(s.verts.data(), s.body.faces.data(), F, div, fc.data());
  DeviceBuffer<FaceFrame<float>> fg(static_cast<size_t>(F));
  cuda::face_frames_cuda(verts.data(), faces.data(), F, div, fg.data());
  const std::vector<double> vd = to_double(s.verts);
  std::vector<FaceFrame<double>> fr(static_cast<size_t>(F));
  compute_face_frames(vd.data(), s.body.faces.data(), F, double(div), fr.data());
  expect_as_accurate("face frames", frames_as_floats(fr), frames_as_floats(fc), frames_as_floats(fg.to_host()), kFwd);

  std::vector<FaceFrameGrad<float>> dfr(static_cast<size_t>(F));
  const std::vector<float> r = randv(17 * size_t(F), -1, 1, 21);
  for (int f = 0; f < F; ++f) {
    const float* q = r.data() + 17 * f;
    dfr[size_t(f)].t = Vec3f(q[0], q[1], q[2]);
    dfr[size_t(f)].R = Mat3f::load(q + 3);
    dfr[size_t(f)].q = Quat<float>(q[12], q[13], q[14], q[15]);
    dfr[size_t(f)].k = q[16];
  }
  std::vector<float> dvc(3 * size_t(V), 0.0f);
  face_frames_backward(s.verts.data(), s.body.faces.data(), F, div, dfr.data(), dvc.data());
  DeviceBuffer<FaceFrameGrad<float>> dfg(dfr.size());
  dfg.upload(dfr);
  DeviceBuffer<float> dvg(3 * size_t(V));
  dvg.zero();
  cuda::face_frames_backward_cuda(verts.data(), faces.data(), F, div, dfg.data(), dvg.data());
  expect_close("face frames d_verts", dvc, dvg.to_host(), kGrad);

  // Gaussians
  const GaussianLocalView<float> lc{N, s.face.data(), s.offset.data(), s.rotation.data(), s.scale.data()};
  std::vector<float> mc(3 * size_t(N)), qc(4 * size_t(N)), sc(3 * size_t(N));
  pose_gaussians(s.verts.data(), s.body.faces.data(), F, div, lc, mc.data(), qc.data(), sc.data());
  DeviceBuffer<int32_t> gface = up(s.face);
  DeviceBuffer<float> goff = up(s.offset), grot = up(s.rotation), gscale = up(s.scale);
  const GaussianLocalView<float> lg{N, gface.data(), goff.data(), grot.data(), gscale.data()};
  cuda::check_indices_cuda(gface.data(), N, F, "gaussians");
  DeviceBuffer<float> mg(3 * size_t(N)), qg(4 * size_t(N)), sg(3 * size_t(N));
  cuda::PoseGaussiansScratch scratch;
  cuda::pose_gaussians_cuda(verts.data(), faces.data(), F, div, lg, mg.data(), qg.data(), sg.data(), scratch);
  const std::vector<double> od = to_double(s.offset), rd = to_double(s.rotation), sd = to_double(s.scale);
  const GaussianLocalView<double> ld{N, s.face.data(), od.data(), rd.data(), sd.data()};
  std::vector<double> mr(mc.size()), qr(qc.size()), sr(sc.size());
  pose_gaussians(vd.data(), s.body.faces.data(), F, double(div), ld, mr.data(), qr.data(), sr.data());
  expect_as_accurate("posed means", mr, mc, mg.to_host(), kFwd);
  expect_as_accurate("posed quats", qr, qc, qg.to_host(), kFwd);
  expect_as_accurate("posed scales", sr, sc, sg.to_host(), kFwd);

  const std::vector<float> dm = randv(3 * size_t(N), -1, 1, 31), dq = randv(4 * size_t(N), -1, 1, 32),
                           ds = randv(3 * size_t(N), -1, 1, 33);
  std::vector<float> gv(3 * size_t(V), 0.0f), go(3 * size_t(N), 0.0f), gr(4 * size_t(N), 0.0f), gs(3 * size_t(N), 0.0f);
  pose_gaussians_backward(s.verts.data(), s.body.faces.data(), F, div, lc, dm.data(), dq.data(), ds.data(), gv.data(),
                          go.data(), gr.data(), gs.data());
  DeviceBuffer<float> dmg = up(dm), dqg = up(dq), dsg = up(ds);
  DeviceBuffer<float> gvg(gv.size()), gog(go.size()), grg(gr.size()), gsg(gs.size());
  for (auto* b : {&gvg, &gog, &grg, &gsg}) b->zero();
  cuda::pose_gaussians_backward_cuda(verts.data(), faces.data(), F, div, lg, dmg.data(), dqg.data(), dsg.data(),
                                     gvg.data(), gog.data(), grg.data(), gsg.data(), scratch);
  const std::vector<double> dmd = to_double(dm), dqd = to_double(dq), dsd = to_double(ds);
  std::vector<double> gvr(gv.size(), 0.0), gor(go.size(), 0.0), grr(gr.size(), 0.0), gsr(gs.size(), 0.0);
  pose_gaussians_backward(vd.data(), s.body.faces.data(), F, double(div), ld, dmd.data(), dqd.data(), dsd.data(),
                          gvr.data(), gor.data(), grr.data(), gsr.data());
  expect_as_accurate("pose d_verts", gvr, gv, gvg.to_host(), kGrad);
  expect_as_accurate("pose d_offset", gor, go, gog.to_host(), kFwd);  // per-Gaussian, no reduction
  expect_as_accurate("pose d_rotation", grr, gr, grg.to_host(), kFwd);
  expect_as_accurate("pose d_scale", gsr, gs, gsg.to_host(), kFwd);

  // A bad face index is reported.
  std::vector<int32_t> bad = s.face;
  bad[17] = F;
  DeviceBuffer<int32_t> badg = up(bad);
  EXPECT_THROW(cuda::check_indices_cuda(badg.data(), N, F, "gaussians"), Error);
}

// ------------------------------------------------------------------ Gaussian rasterizer

struct RasterScene {
  int n = 0, W = 0, H = 0, sh_degree = 0;
  std::vector<float> means, quats, scales, opacities, colors, sh, depth_map, background;
  Camera cam;
};

RasterScene raster_scene(bool use_sh, uint64_t seed) {
  RasterScene s;
  s.n = 2500;
  s.W = 173;  // not multiples of the tile size: partial tiles
  s.H = 131;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  for (int i = 0; i < s.n; ++i) {
    s.means.insert(s.means.end(), {1.3f * U(rng), 1.0f * U(rng), 3.0f + U(rng)});
    for (int k = 0; k < 4; ++k) s.quats.push_back(U(rng));
    for (int k = 0; k < 3; ++k) s.scales.push_back(0.01f + 0.04f * (U(rng) + 1.0f));
    s.opacities.push_back(0.55f + 0.44f * U(rng));
    for (int k = 0; k < 3; ++k) s.colors.push_back(0.5f + 0.5f * U(rng));
  }
  if (use_sh) {
    s.sh_degree = 3;
    s.sh.resize(size_t(s.n) * 16 * 3);
    for (float& v : s.sh) v = 0.4f * U(rng);
  }
  s.depth_map.resize(size_t(s.W) * s.H);
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x)  // a tilted occluder through the cloud, +inf in one corner
      s.depth_map[size_t(y) * s.W + x] = (x > 140 && y < 30) ? INFINITY : 2.6f + 0.008f * float(x) + 0.002f * float(y);
  s.background = randv(3 * size_t(s.W) * s.H, 0, 1, seed + 1);
  s.cam.width = s.W;
  s.cam.height = s.H;
  s.cam.fx = s.cam.fy = 120.0f;
  s.cam.cx = 86.0f;
  s.cam.cy = 66.0f;
  return s;
}

void raster_parity(bool use_sh, bool antialiased, bool depth, bool per_pixel_bg) {
  const RasterScene s = raster_scene(use_sh, use_sh ? 41 : 42);
  const size_t P = size_t(s.W) * s.H, n = size_t(s.n);
  GaussianInputs<float> hin;
  hin.count = s.n;
  hin.means = s.means.data();
  hin.quats = s.quats.data();
  hin.scales = s.scales.data();
  hin.opacities = s.opacities.data();
  if (use_sh) {
    hin.sh = s.sh.data();
    hin.sh_degree = s.sh_degree;
  } else {
    hin.colors = s.colors.data();
  }
  GaussianRasterSettings<float> hs;
  hs.antialiased = antialiased;
  hs.depth_map = depth ? s.depth_map.data() : nullptr;
  hs.background = per_pixel_bg ? s.background.data() : nullptr;
  hs.background_color = Vec3f(0.2f, 0.5f, 0.9f);

  std::vector<float> cc(3 * P), ca(P), cd(P), ck(3 * P);
  GaussianRasterState<float> cst;
  rasterize_gaussians(hin, s.cam, hs, cst, {cc.data(), ca.data(), cd.data(), ck.data()});

  DeviceBuffer<float> m = up(s.means), q = up(s.quats), sc = up(s.scales), op = up(s.opacities), col = up(s.colors),
                      sh = up(s.sh), dm = up(s.depth_map), bg = up(s.background);
  GaussianInputs<float> din = hin;
  din.means = m.data();
  din.quats = q.data();
  din.scales = sc.data();
  din.opacities = op.data();
  if (use_sh)
    din.sh = sh.data();
  else
    din.colors = col.data();
  GaussianRasterSettings<float> ds = hs;
  ds.depth_map = depth ? dm.data() : nullptr;
  ds.background = per_pixel_bg ? bg.data() : nullptr;
  DeviceBuffer<float> gc(3 * P), ga(P), gd(P), gk(3 * P);
  cuda::GaussianRasterCudaState gst;
  cuda::rasterize_gaussians_cuda(din, s.cam, ds, gst, {gc.data(), ga.data(), gd.data(), gk.data()});

  EXPECT_NEAR(double(gst.num_pairs), double(cst.pairs()), kCutFrac * double(cst.pairs())) << "pair count";
  expect_close("raster color", cc, gc.to_host(), kFwd * 10, kCutFrac);
  expect_close("raster alpha", ca, ga.to_host(), kFwd * 10, kCutFrac);
  expect_close("raster depth", cd, gd.to_host(), kFwd * 10, kCutFrac);
  expect_close("raster composite", ck, gk.to_host(), kFwd * 10, kCutFrac);
  const std::vector<int32_t> radii_g = gst.radii.to_host();
  int64_t radii_diff = 0;
  for (size_t i = 0; i < n; ++i) radii_diff += (cst.radii[i] > 0) != (radii_g[i] > 0);
  EXPECT_LE(radii_diff, int64_t(kCutFrac * double(n)) + 1) << "visibility differs for " << radii_diff << " Gaussians";

  // Backward with gradients on every output.
  const std::vector<float> d_color = randv(3 * P, -1, 1, 51), d_alpha = randv(P, -1, 1, 52),
                           d_depth = randv(P, -1, 1, 53), d_comp = randv(3 * P, -1, 1, 54);
  const size_t ksh = use_sh ? 48 : 0;
  std::vector<float> gm(3 * n), gq(4 * n), gs(3 * n), go(n), gcol(3 * n), gsh(ksh * n), gm2(2 * n), acc(n, 0.5f),
      gbg(3 * P), gbgc(3), cost(n, 0.25f);
  GaussianGrads<float> hg;
  hg.means = gm.data();
  hg.quats = gq.data();
  hg.scales = gs.data();
  hg.opacities = go.data();
  hg.colors = gcol.data();
  hg.sh = use_sh ? gsh.data() : nullptr;
  hg.means2d = gm2.data();
  hg.means2d_norm_accum = acc.data();
  hg.background = gbg.data();
  hg.background_color = gbgc.data();
  hg.removal_cost = cost.data();
  rasterize_gaussians_backward(hin, s.cam, hs, cst, {d_color.data(), d_alpha.data(), d_depth.data(), d_comp.data()},
                               hg);

  DeviceBuffer<float> ddc = up(d_color), dda = up(d_alpha), ddd = up(d_depth), ddk = up(d_comp);
  DeviceBuffer<float> bm(3 * n), bq(4 * n), bs(3 * n), bo(n), bcol(3 * n), bsh(std::max<size_t>(1, ksh * n)),
      bm2(2 * n), bacc(std::vector<float>(n, 0.5f)), bbg(3 * P), bbgc(3), bcost(std::vector<float>(n, 0.25f));
  GaussianGrads<float> dg;
  dg.means = bm.data();
  dg.quats = bq.data();
  dg.scales = bs.data();
  dg.opacities = bo.data();
  dg.colors = bcol.data();
  dg.sh = use_sh ? bsh.data() : nullptr;
  dg.means2d = bm2.data();
  dg.means2d_norm_accum = bacc.data();
  dg.background = bbg.data();
  dg.background_color = bbgc.data();
  dg.removal_cost = bcost.data();
  cuda::rasterize_gaussians_backward_cuda(din, s.cam, ds, gst, {ddc.data(), dda.data(), ddd.data(), ddk.data()}, dg);

  // A flipped cut changes a few Gaussians' sums: allow kCutFrac of them, or 3.
  const double frac = std::max(kCutFrac, 3.0 / double(n));
  expect_close("d_means", gm, bm.to_host(), kGrad, frac);
  expect_close("d_quats", gq, bq.to_host(), kGrad, frac);
  expect_close("d_scales", gs, bs.to_host(), kGrad, frac);
  expect_close("d_opacities", go, bo.to_host(), kGrad, frac);
  expect_close("d_means2d", gm2, bm2.to_host(), kGrad, frac);
  expect_close("means2d_norm_accum", acc, bacc.to_host(), kGrad, frac);
  expect_close("removal_cost", cost, bcost.to_host(), kGrad, frac);
  if (use_sh) {
    std::vector<float> h = bsh.to_host();
    h.resize(ksh * n);
    expect_close("d_sh", gsh, h, kGrad, frac);
  } else {
    expect_close("d_colors", gcol, bcol.to_host(), kGrad, frac);
  }
  if (per_pixel_bg)
    expect_close("d_background", gbg, bbg.to_host(), kFwd * 10, kCutFrac);
  else
    expect_close("d_background_color", gbgc, bbgc.to_host(), kGrad);
}

TEST(CudaParity, GaussianRasterColorsDepthMapPerPixelBackground) {
  REQUIRE_CUDA();
  raster_parity(false, false, true, true);
}
TEST(CudaParity, GaussianRasterShAntialiasedNoOccluder) {
  REQUIRE_CUDA();
  raster_parity(true, true, false, false);
}
TEST(CudaParity, GaussianRasterShOccluderBackgroundColour) {
  REQUIRE_CUDA();
  raster_parity(true, false, true, false);
}

TEST(CudaParity, GaussianRasterEmptyAndCulledScenes) {
  REQUIRE_CUDA();
  Camera cam;
  cam.width = 40;
  cam.height = 24;
  cam.fx = cam.fy = 30;
  cam.cx = 20;
  cam.cy = 12;
  // No Gaussians; then only Gaussians behind the camera.
  for (int n : {0, 3}) {
    std::vector<float> means = {0, 0, -1, 0, 0, -2, 0, 0, -3}, quats(12, 0.5f), scales(9, 0.1f), op(3, 0.9f),
                       col(9, 0.5f);
    DeviceBuffer<float> m = up(means), q = up(quats), s = up(scales), o = up(op), c = up(col);
    GaussianInputs<float> in;
    in.count = n;
    in.means = m.data();
    in.quats = q.data();
    in.scales = s.data();
    in.opacities = o.data();
    in.colors = c.data();
    GaussianRasterSettings<float> st;
    st.background_color = Vec3f(0.1f, 0.2f, 0.3f);
    DeviceBuffer<float> img(size_t(3) * 40 * 24), alpha(size_t(40) * 24);
    cuda::GaussianRasterCudaState state;
    GaussianRasterOutputs<float> out;
    out.composite = img.data();
    out.alpha = alpha.data();
    cuda::rasterize_gaussians_cuda(in, cam, st, state, out);
    const std::vector<float> h = img.to_host();
    for (size_t p = 0; p < h.size(); p += 3) {
      ASSERT_EQ(h[p], 0.1f);
      ASSERT_EQ(h[p + 2], 0.3f);
    }
    for (float a : alpha.to_host()) ASSERT_EQ(a, 0.0f);
    EXPECT_EQ(state.num_pairs, 0);
    DeviceBuffer<float> dimg(std::vector<float>(h.size(), 1.0f)), dm(9), dq(12), ds(9), dop(3), dc(9), dbg(3);
    GaussianGrads<float> g;
    g.means = dm.data();
    g.quats = dq.data();
    g.scales = ds.data();
    g.opacities = dop.data();
    g.colors = dc.data();
    g.background_color = dbg.data();
    GaussianRasterOutputGrads<float> dout;
    dout.composite = dimg.data();
    cuda::rasterize_gaussians_backward_cuda(in, cam, st, state, dout, g);
    const std::vector<float> gb = dbg.to_host();
    for (float v : gb) EXPECT_FLOAT_EQ(v, 40.0f * 24.0f);  // d/dbg of sum(composite) = pixel count
    for (float v : dm.to_host()) EXPECT_EQ(v, 0.0f);
  }
}

// ------------------------------------------------------------------ mesh, texture

TEST(CudaParity, MeshRasterInterpolateTexture) {
  REQUIRE_CUDA();
  const testgpu::AvatarScene s = testgpu::make_avatar_scene(BodyResolution::low, 0, 211, 190, 8, 128);
  const Camera& cam = s.cam;
  const int P = cam.width * cam.height, V = s.body.num_verts, F = s.body.num_faces;
  const MeshView mc{s.verts.data(), V, s.body.faces.data(), F};
  MeshRaster rc;
  rasterize_mesh(cam, mc, rc);
  DeviceBuffer<float> verts = up(s.verts);
  DeviceBuffer<int32_t> faces = up(s.body.faces);
  const MeshView mg{verts.data(), V, faces.data(), F};
  cuda::MeshRasterCuda rg;
  cuda::rasterize_mesh_cuda(cam, mg, rg);
  const std::vector<int32_t> tri_g = rg.tri.to_host();
  int64_t covered = 0, diff = 0;
  for (int p = 0; p < P; ++p) {
    covered += rc.tri[size_t(p)] >= 0;
    diff += rc.tri[size_t(p)] != tri_g[size_t(p)];
  }
  EXPECT_GT(covered, P / 10) << "the body should cover the image";
  EXPECT_LE(diff, int64_t(kCutFrac * double(covered)) + 1) << diff << " pixels see another face";
  {
    const std::vector<float> bg = rg.bary.to_host(), dg = rg.depth.to_host(), mkg = rg.mask.to_host();
    const std::vector<double> vd = to_double(s.verts);
    std::vector<double> bary_r(3 * size_t(P)), depth_r(static_cast<size_t>(P));
    mesh_barycentrics(cam.cast<double>(), MeshViewT<double>{vd.data(), V, s.body.faces.data(), F}, rc.tri.data(),
                      bary_r.data(), depth_r.data());
    std::vector<float> b1, b2, d1, d2;
    std::vector<double> br, dr;
    for (int p = 0; p < P; ++p) {
      if (rc.tri[size_t(p)] != tri_g[size_t(p)]) continue;
      for (int k = 0; k < 3; ++k) {
        b1.push_back(rc.bary[3 * size_t(p) + k]), b2.push_back(bg[3 * size_t(p) + k]);
        br.push_back(bary_r[3 * size_t(p) + k]);
      }
      d1.push_back(rc.depth[size_t(p)]);
      d2.push_back(dg[size_t(p)]);
      dr.push_back(depth_r[size_t(p)]);
      EXPECT_EQ(rc.mask[size_t(p)], mkg[size_t(p)]);
    }
    expect_as_accurate("mesh bary", br, b1, b2, kFwd * 10);
    expect_as_accurate("mesh depth", dr, d1, d2, kFwd);
  }
  // The differentiable kernels on the CPU's visibility (independent of coverage flips).
  DeviceBuffer<int32_t> tri = up(rc.tri);
  DeviceBuffer<float> bary = up(rc.bary);
  const std::vector<float> gbary = randv(3 * size_t(P), -1, 1, 61), gdepth = randv(size_t(P), -1, 1, 62);
  std::vector<float> gv(3 * size_t(V), 0.0f);
  mesh_barycentrics_backward(cam, mc, rc.tri.data(), gbary.data(), gdepth.data(), gv.data());
  DeviceBuffer<float> gbd = up(gbary), gdd = up(gdepth), gvg(3 * size_t(V));
  gvg.zero();
  cuda::mesh_barycentrics_backward_cuda(cam, mg, tri.data(), gbd.data(), gdd.data(), gvg.data());
  const std::vector<double> vd = to_double(s.verts), gbary_d = to_double(gbary), gdepth_d = to_double(gdepth);
  std::vector<double> gv_r(gv.size(), 0.0);
  mesh_barycentrics_backward(cam.cast<double>(), MeshViewT<double>{vd.data(), V, s.body.faces.data(), F}, rc.tri.data(),
                             gbary_d.data(), gdepth_d.data(), gv_r.data());
  expect_as_accurate("mesh d_verts", gv_r, gv, gvg.to_host(), kGrad);

  const int T = s.body.num_uv();
  std::vector<float> uvc(2 * size_t(P));
  interpolate(P, rc.tri.data(), rc.bary.data(), s.body.ft.data(), s.body.vt.data(), 2, uvc.data());
  DeviceBuffer<int32_t> ft = up(s.body.ft);
  DeviceBuffer<float> vt = up(s.body.vt), uvg(2 * size_t(P));
  cuda::interpolate_cuda(P, tri.data(), bary.data(), ft.data(), vt.data(), 2, uvg.data());
  expect_close("interpolated uv", uvc, uvg.to_host(), kFwd);
  const std::vector<float> guv = randv(2 * size_t(P), -1, 1, 63);
  std::vector<float> gvt(2 * size_t(T), 0.0f), gb(3 * size_t(P));
  interpolate_backward(P, T, rc.tri.data(), rc.bary.data(), s.body.ft.data(), s.body.vt.data(), 2, guv.data(),
                       gvt.data(), gb.data());
  DeviceBuffer<float> guvg = up(guv), gvtg(2 * size_t(T)), gbg(3 * size_t(P));
  gvtg.zero();
  cuda::interpolate_backward_cuda(P, tri.data(), bary.data(), ft.data(), vt.data(), 2, guvg.data(), gvtg.data(),
                                  gbg.data());
  expect_close("interpolate d_attr", gvt, gvtg.to_host(), kGrad);
  expect_close("interpolate d_bary", gb, gbg.to_host(), kFwd);

  const TextureView th = s.texture_view();
  DeviceBuffer<float> texd = up(s.texture);
  const TextureView tg{th.width, th.height, 3, texd.data()};
  std::vector<float> colc(3 * size_t(P));
  sample_texture(th, P, rc.tri.data(), uvc.data(), colc.data());
  DeviceBuffer<float> uvcd = up(uvc), colg(3 * size_t(P));
  cuda::sample_texture_cuda(tg, P, tri.data(), uvcd.data(), colg.data());
  expect_close("texture sample", colc, colg.to_host(), kFwd);
  const std::vector<float> gcol = randv(3 * size_t(P), -1, 1, 64);
  std::vector<float> gtex(s.texture.size(), 0.0f), guvc(2 * size_t(P));
  sample_texture_backward(th, P, rc.tri.data(), uvc.data(), gcol.data(), gtex.data(), guvc.data());
  DeviceBuffer<float> gcold = up(gcol), gtexg(s.texture.size()), guvcg(2 * size_t(P));
  gtexg.zero();
  cuda::sample_texture_backward_cuda(tg, P, tri.data(), uvcd.data(), gcold.data(), gtexg.data(), guvcg.data());
  expect_close("texture d_texels", gtex, gtexg.to_host(), kGrad);
  expect_close("texture d_uv", guvc, guvcg.to_host(), kFwd * 10);  // per pixel; fractional parts of u W
}

// The coverage cut (render/mesh_raster.h): the same faces drawn, cut and skipped.
TEST(CudaParity, MeshRasterCoverageCut) {
  REQUIRE_CUDA();
  const testgpu::AvatarScene s = testgpu::make_avatar_scene(BodyResolution::low, 0, 211, 190, 8, 128);
  const Camera& cam = s.cam;
  const int P = cam.width * cam.height, V = s.body.num_verts, F = s.body.num_faces;
  const std::vector<float> cov = randv(size_t(V), 0, 1, 65);  // every kind of face: whole, cut, skipped
  MeshRaster rc;
  rasterize_mesh(cam, MeshView{s.verts.data(), V, s.body.faces.data(), F, cov.data()}, rc);
  DeviceBuffer<float> verts = up(s.verts), covd = up(cov);
  DeviceBuffer<int32_t> faces = up(s.body.faces);
  cuda::MeshRasterCuda rg;
  cuda::rasterize_mesh_cuda(cam, MeshView{verts.data(), V, faces.data(), F, covd.data()}, rg);
  const std::vector<int32_t> tri_g = rg.tri.to_host();
  int64_t covered = 0, diff = 0;
  for (int p = 0; p < P; ++p) {
    covered += rc.tri[size_t(p)] >= 0;
    diff += rc.tri[size_t(p)] != tri_g[size_t(p)];
  }
  EXPECT_GT(covered, P / 40) << "the cut body should still cover part of the image";
  EXPECT_LE(diff, int64_t(kCutFrac * double(covered)) + 1) << diff << " pixels see another face";
}

TEST(CudaParity, MeshRasterCameraErrors) {
  Camera cam;
  cam.width = 0;
  cuda::MeshRasterCuda out;
  EXPECT_THROW(cuda::rasterize_mesh_cuda(cam, MeshView{}, out), Error);  // checked before any CUDA call
}

// ------------------------------------------------------------------ merge

TEST(CudaParity, MergeForwardBackward) {
  REQUIRE_CUDA();
  const int P = 5000;
  const std::vector<float> cf = randv(3 * P, 0, 1, 71), al = randv(P, 0, 1, 72), mc = randv(3 * P, 0, 1, 73),
                           mm = randv(P, 0, 1, 74), bgp = randv(3 * P, 0, 1, 75), go = randv(3 * P, -1, 1, 76);
  for (bool per_pixel : {false, true}) {
    MergeInputs h;
    h.num_pixels = P;
    h.color_front = cf.data();
    h.alpha = al.data();
    h.mesh_color = mc.data();
    h.mesh_mask = mm.data();
    h.background = per_pixel ? bgp.data() : nullptr;
    h.background_color[0] = 0.3f;
    h.background_color[1] = 0.6f;
    h.background_color[2] = 0.9f;
    std::vector<float> oc(3 * P);
    merge(h, oc.data());
    std::vector<float> gcf(3 * P), gal(P), gmc(3 * P), gmm(P), gbg(3 * P), gbc = {0.5f, 0.5f, 0.5f};
    merge_backward(h, go.data(), MergeGrads{gcf.data(), gal.data(), gmc.data(), gmm.data(), gbg.data(), gbc.data()});

    DeviceBuffer<float> dcf = up(cf), dal = up(al), dmc = up(mc), dmm = up(mm), dbg = up(bgp), dgo = up(go);
    MergeInputs d = h;
    d.color_front = dcf.data();
    d.alpha = dal.data();
    d.mesh_color = dmc.data();
    d.mesh_mask = dmm.data();
    d.background = per_pixel ? dbg.data() : nullptr;
    DeviceBuffer<float> og(3 * P);
    cuda::merge_cuda(d, og.data());
    expect_close("merge", oc, og.to_host(), kFwd);
    DeviceBuffer<float> b1(3 * P), b2(P), b3(3 * P), b4(P), b5(3 * P), b6(std::vector<float>(3, 0.5f));
    cuda::merge_backward_cuda(d, dgo.data(), MergeGrads{b1.data(), b2.data(), b3.data(), b4.data(), b5.data(), b6.data()});
    const std::vector<double> cfd = to_double(cf), ald = to_double(al), mcd = to_double(mc), mmd = to_double(mm),
                              bgd = to_double(bgp), god = to_double(go);
    MergeInputsT<double> r;
    r.num_pixels = P;
    r.color_front = cfd.data();
    r.alpha = ald.data();
    r.mesh_color = mcd.data();
    r.mesh_mask = mmd.data();
    r.background = per_pixel ? bgd.data() : nullptr;
    for (int c = 0; c < 3; ++c) r.background_color[c] = double(h.background_color[c]);
    std::vector<double> rcf(3 * P), ral(P), rmc(3 * P), rmm(P), rbg(3 * P), rbc(3, 0.5);
    merge_backward(r, god.data(),
                   MergeGradsT<double>{rcf.data(), ral.data(), rmc.data(), rmm.data(), rbg.data(), rbc.data()});
    expect_as_accurate("merge d_color_front", rcf, gcf, b1.to_host(), kFwd);
    expect_as_accurate("merge d_alpha", ral, gal, b2.to_host(), kFwd);
    expect_as_accurate("merge d_mesh_color", rmc, gmc, b3.to_host(), kFwd);
    expect_as_accurate("merge d_mesh_mask", rmm, gmm, b4.to_host(), kFwd);
    expect_as_accurate("merge d_background", rbg, gbg, b5.to_host(), kFwd);
    expect_close("merge d_background_color", gbc, b6.to_host(), kGrad);
  }
}

// ------------------------------------------------------------------ losses

TEST(CudaParity, ImageLosses) {
  REQUIRE_CUDA();
  const int H = 97, W = 131, P = H * W;
  const std::vector<float> x = randv(3 * size_t(P), 0, 1, 81), y = randv(3 * size_t(P), 0, 1, 82);
  std::vector<float> w = randv(size_t(P), 0, 1, 83);
  for (size_t i = 0; i < w.size(); i += 7) w[i] = 0.0f;  // a mask with holes
  DeviceBuffer<float> xd = up(x), yd = up(y), wd = up(w);
  cuda::LossCudaScratch gs;
  LossScratch<float> cs;
  for (bool weighted : {false, true}) {
    const float* wc = weighted ? w.data() : nullptr;
    const float* wg = weighted ? wd.data() : nullptr;
    const std::string tag = weighted ? " (weighted)" : "";
    std::vector<float> gc(3 * size_t(P), 0.25f);
    DeviceBuffer<float> gg(gc);
    float vc = l2_loss(x.data(), y.data(), H, W, wc, gc.data(), 0.7f);
    float vg = cuda::l2_loss_cuda(xd.data(), yd.data(), H, W, gs, wg, gg.data(), 0.7f);
    expect_close_scalar("l2" + tag, vc, vg, kLoss);
    expect_close("l2 grad" + tag, gc, gg.to_host(), kFwd);
    vc = ssim_loss(x.data(), y.data(), H, W, cs, wc, gc.data(), 0.7f);
    vg = cuda::ssim_loss_cuda(xd.data(), yd.data(), H, W, gs, wg, gg.data(), 0.7f);
    expect_close_scalar("ssim" + tag, vc, vg, kLoss);
    expect_close("ssim grad" + tag, gc, gg.to_host(), kGrad);
    vc = edge_loss(x.data(), y.data(), H, W, cs, wc, gc.data(), 0.7f);
    vg = cuda::edge_loss_cuda(xd.data(), yd.data(), H, W, gs, wg, gg.data(), 0.7f);
    expect_close_scalar("edge" + tag, vc, vg, kLoss);
    expect_close("edge grad" + tag, gc, gg.to_host(), kGrad);
  }
  // An all-zero mask: value 0, gradient untouched, as on the CPU.
  DeviceBuffer<float> zero(std::vector<float>(size_t(P), 0.0f)), g(std::vector<float>(3 * size_t(P), 1.0f));
  EXPECT_EQ(cuda::ssim_loss_cuda(xd.data(), yd.data(), H, W, gs, zero.data(), g.data()), 0.0f);
  for (float v : g.to_host()) ASSERT_EQ(v, 1.0f);
}

// ------------------------------------------------------------------ Adam, KNN, gather

TEST(CudaParity, AdamSteps) {
  REQUIRE_CUDA();
  const int n = 30000;
  std::vector<float> pc = randv(n, -1, 1, 91);
  DeviceBuffer<float> pg = up(pc);
  Adam ac;
  cuda::AdamCuda ag;
  ac.add_group("x", n, 1e-2);
  ag.add_group("x", n, 1e-2);
  // The float64 reference of the same update (train/adam.h adam_update).
  std::vector<double> pr = to_double(pc), mr(size_t(n), 0.0), vr(size_t(n), 0.0);
  const AdamConfig k = ac.config();
  for (int step = 0; step < 4; ++step) {
    std::vector<float> g = randv(n, -1, 1, 100 + step);
    for (size_t i = 0; i < g.size(); i += 11) g[i] = 0.0f;  // zero gradients: only decay
    DeviceBuffer<float> gd = up(g);
    ac.step(0, pc.data(), g.data());
    ag.step(0, pg.data(), gd.data());
    const double bc1 = 1 - std::pow(k.beta1, step + 1), bc2 = 1 - std::pow(k.beta2, step + 1);
    for (size_t i = 0; i < size_t(n); ++i) {
      mr[i] = k.beta1 * mr[i] + (1 - k.beta1) * g[i];
      vr[i] = k.beta2 * vr[i] + (1 - k.beta2) * double(g[i]) * g[i];
      pr[i] -= 1e-2 / bc1 * mr[i] / (std::sqrt(vr[i] / bc2) + k.eps);
    }
  }
  expect_as_accurate("adam params", pr, pc, pg.to_host(), kFwd);
  expect_as_accurate("adam m", mr, ac.first_moment(0), ag.first_moment(0), kFwd);
  expect_as_accurate("adam v", vr, ac.second_moment(0), ag.second_moment(0), kFwd);
  // Reindexing moves each side's own values exactly (new rows start at zero).
  const std::vector<int64_t> src = {5, -1, 7, 7, 0};
  auto gathered = [&](const std::vector<float>& v) {
    std::vector<float> out;
    for (int64_t e : src) out.push_back(e < 0 ? 0.0f : v[size_t(e)]);
    return out;
  };
  const std::vector<float> mc = gathered(ac.first_moment(0)), vc = gathered(ac.second_moment(0)),
                           mg = gathered(ag.first_moment(0)), vg = gathered(ag.second_moment(0));
  ac.reindex(0, src);
  ag.reindex(0, src);
  EXPECT_EQ(ac.first_moment(0), mc);
  EXPECT_EQ(ac.second_moment(0), vc);
  EXPECT_EQ(ag.first_moment(0), mg);
  EXPECT_EQ(ag.second_moment(0), vg);
  EXPECT_THROW(ag.reindex(0, {9}), Error);
}

TEST(CudaParity, KnnRegulariser) {
  REQUIRE_CUDA();
  const int n = 3000, K = 4;
  const std::vector<float> pos = randv(3 * size_t(n), -1, 1, 111), rot = randv(4 * size_t(n), -1, 1, 112),
                           scl = randv(3 * size_t(n), 0, 1, 113), opa = randv(size_t(n), 0, 1, 114),
                           col = randv(3 * size_t(n), 0, 1, 115);
  std::vector<int32_t> sets(size_t(n) * K);
  knn_sets(pos.data(), n, K, sets.data());
  sets[5] = -1;  // absent members are skipped
  sets[9] = n + 3;
  KnnRegWeights w;
  w.rotation = 0.5;
  w.distance = 2.0;
  std::vector<float> g1(pos.size(), 0), g2(rot.size(), 0), g3(scl.size(), 0), g4(opa.size(), 0), g5(col.size(), 0);
  const KnnRegInputs<float> ic{n, pos.data(), rot.data(), scl.data(), opa.data(), col.data()};
  const KnnRegGrads<float> gc{g1.data(), g2.data(), g3.data(), g4.data(), g5.data()};
  const float vc = knn_reg(ic, sets.data(), K, w, &gc, 0.3f);

  DeviceBuffer<float> dp = up(pos), dr = up(rot), ds = up(scl), dq = up(opa), dc = up(col);
  DeviceBuffer<int32_t> dsets = up(sets);
  DeviceBuffer<float> h1(g1.size()), h2(g2.size()), h3(g3.size()), h4(g4.size()), h5(g5.size());
  for (auto* b : {&h1, &h2, &h3, &h4, &h5}) b->zero();
  const KnnRegInputs<float> ig{n, dp.data(), dr.data(), ds.data(), dq.data(), dc.data()};
  const KnnRegGrads<float> gg{h1.data(), h2.data(), h3.data(), h4.data(), h5.data()};
  const float vg = cuda::knn_reg_cuda(ig, dsets.data(), K, w, &gg, 0.3f);
  expect_close_scalar("knn value", vc, vg, kLoss);
  expect_close("knn d_position", g1, h1.to_host(), kGrad);
  expect_close("knn d_rotation", g2, h2.to_host(), kGrad);
  expect_close("knn d_scale", g3, h3.to_host(), kGrad);
  expect_close("knn d_opacity", g4, h4.to_host(), kGrad);
  expect_close("knn d_color", g5, h5.to_host(), kGrad);
}

TEST(CudaParity, GatherRows) {
  REQUIRE_CUDA();
  const std::vector<float> src = {0, 1, 2, 10, 11, 12, 20, 21, 22};
  const std::vector<int64_t> rows = {2, -1, 0, 2};
  DeviceBuffer<float> s = up(src), d(12);
  DeviceBuffer<int64_t> r = up(rows);
  cuda::gather_rows_cuda(s.data(), 3, r.data(), 4, d.data(), -1.0f);
  EXPECT_EQ(d.to_host(), (std::vector<float>{20, 21, 22, -1, -1, -1, 0, 1, 2, 20, 21, 22}));
}

// ------------------------------------------------------------------ the avatar render chain

void avatar_render_parity(bool antialias) {
  const testgpu::AvatarScene s = testgpu::make_avatar_scene(BodyResolution::low, 3000, 160, 150, 12, 128);
  const int P = s.cam.width * s.cam.height, V = s.body.num_verts, N = s.num_gaussians();
  const GaussianSetView gh = s.gaussians();
  const TextureView th = s.texture_view();
  AvatarRenderRequest rc;
  rc.camera = &s.cam;
  BodyTopology topology = topology_of(s.body);
  const std::vector<int32_t> neighbors = mesh_face_neighbors(s.body.faces.data(), s.body.num_faces, V);
  topology.face_neighbors = neighbors.data();
  rc.body = &topology;
  rc.antialias = antialias;
  rc.verts = s.verts.data();
  rc.face_scale_divisor = s.divisor;
  rc.gaussians = &gh;
  rc.texture = &th;
  rc.depth_margin = 0.01f;
  rc.background[0] = 1.0f;
  rc.background[1] = 0.5f;
  AvatarRenderBuffers bc;
  render_avatar(rc, bc);

  cuda::AvatarBodyCuda body(s.body);
  DeviceBuffer<float> verts = up(s.verts), off = up(s.offset), rot = up(s.rotation), scl = up(s.scale),
                      col = up(s.color), opa = up(s.opacity), tex = up(s.texture);
  DeviceBuffer<int32_t> face = up(s.face);
  const GaussianSetView gd{N, face.data(), off.data(), rot.data(), scl.data(), col.data(), opa.data()};
  const TextureView td{th.width, th.height, 3, tex.data()};
  AvatarRenderRequest rg;
  rg.camera = &s.cam;
  rg.body = &body.topology;
  rg.verts = verts.data();
  rg.face_scale_divisor = s.divisor;
  rg.gaussians = &gd;
  rg.texture = &td;
  rg.depth_margin = 0.01f;
  rg.antialias = antialias;
  rg.background[0] = 1.0f;
  rg.background[1] = 0.5f;
  cuda::AvatarRenderCudaBuffers bg;
  cuda::render_avatar_cuda(rg, bg);
  expect_close("avatar image", bc.image, bg.image.to_host(), kFwd * 10, kCutFrac);
  expect_close("avatar alpha", bc.alpha, bg.alpha.to_host(), kFwd * 10, kCutFrac);

  const std::vector<float> dimg = randv(3 * size_t(P), -1, 1, 121), dal = randv(size_t(P), -1, 1, 122);
  std::vector<float> gv(3 * size_t(V), 0), go(3 * size_t(N), 0), gr(4 * size_t(N), 0), gs(3 * size_t(N), 0),
      gcol(3 * size_t(N), 0), gop(size_t(N), 0), gt(s.texture.size(), 0), acc(size_t(N), 0), cost(size_t(N), 0);
  AvatarRenderGrads hgr{gv.data(), go.data(), gr.data(), gs.data(), gcol.data(), gop.data(), gt.data(), acc.data()};
  hgr.removal_cost = cost.data();
  render_avatar_backward(rc, bc, dimg.data(), dal.data(), nullptr, hgr);
  DeviceBuffer<float> ddimg = up(dimg), ddal = up(dal);
  DeviceBuffer<float> hv(gv.size()), ho(go.size()), hr(gr.size()), hs(gs.size()), hc(gcol.size()), hop(gop.size()),
      ht(gt.size()), hacc(acc.size()), hcost(cost.size());
  for (auto* b : {&hv, &ho, &hr, &hs, &hc, &hop, &ht, &hacc, &hcost}) b->zero();
  AvatarRenderGrads dgr{hv.data(), ho.data(), hr.data(), hs.data(), hc.data(), hop.data(), ht.data(), hacc.data()};
  dgr.removal_cost = hcost.data();
  cuda::render_avatar_backward_cuda(rg, bg, ddimg.data(), ddal.data(), nullptr, dgr);
  // Vertex and texel gradients mix both layers' sums: the coverage cut applies here too.
  const double frac = std::max(kCutFrac, 3.0 / double(N));
  expect_close("avatar d_verts", gv, hv.to_host(), kGrad, kCutFrac);
  expect_close("avatar d_offset", go, ho.to_host(), kGrad, frac);
  expect_close("avatar d_rotation", gr, hr.to_host(), kGrad, frac);
  expect_close("avatar d_scale", gs, hs.to_host(), kGrad, frac);
  expect_close("avatar d_color", gcol, hc.to_host(), kGrad, frac);
  expect_close("avatar d_opacity", gop, hop.to_host(), kGrad, frac);
  expect_close("avatar d_texture", gt, ht.to_host(), kGrad, kCutFrac);
  expect_close("avatar means2d accum", acc, hacc.to_host(), kGrad, frac);
  expect_close("avatar removal cost", cost, hcost.to_host(), kGrad, frac);
}

TEST(CudaParity, AvatarRenderForwardBackward) {
  REQUIRE_CUDA();
  avatar_render_parity(false);
}

// The antialiased mesh silhouette (render/mesh_antialias.h): same orchestration, the
// antialiasing kernels on both sides; its vertex gradient joins d_verts.
TEST(CudaParity, AvatarRenderAntialiasedForwardBackward) {
  REQUIRE_CUDA();
  avatar_render_parity(true);
}

}  // namespace
}  // namespace haha
