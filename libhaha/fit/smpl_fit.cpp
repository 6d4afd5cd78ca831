// SMPL -> SMPL-X fitting (fit/smpl_fit.h).
#include "fit/smpl_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "body/lbs.h"
#include "core/error.h"
#include "train/adam.h"

namespace haha {

namespace {

constexpr int kFitJoints = 22;         // pelvis + 21 body joints: same meaning in SMPL and SMPL-X
constexpr int kFitPose = 3 * kFitJoints;  // global orient + body pose values

}  // namespace

SmplFitResult fit_smplx_to_smpl(const BodyModel& smpl, const BodyModel& smplx, const std::vector<int32_t>& corr,
                                const std::vector<SmplxParams>& smpl_frames, const std::vector<SmplxParams>& init,
                                const SmplFitOptions& opt) {
  const size_t N = smpl_frames.size();
  if (N == 0) fail("smpl fit", "no frames");
  if (!corr.empty() && corr.size() != size_t(smpl.num_verts))
    fail("smpl fit", "correspondence has " + std::to_string(corr.size()) + " entries, the SMPL model " +
                         std::to_string(smpl.num_verts) + " vertices");
  for (int32_t c : corr)
    if (c >= smplx.num_verts) fail("smpl fit", "correspondence names SMPL-X vertex " + std::to_string(c) + ", beyond the model");
  if (!init.empty() && init.size() != N) fail("smpl fit", "initial frames do not match the SMPL frames");
  const int nb = std::min(opt.num_betas, smplx.num_shape);
  const double prior = opt.pose_prior >= 0 ? opt.pose_prior : (corr.empty() ? 1e-4 : 0.0);

  // Targets: the posed SMPL body of every frame.
  const Lbs<float> smpl_lbs(smpl), lbs(smplx);
  const size_t Vs = size_t(smpl.num_verts), Vx = size_t(smplx.num_verts);
  std::vector<std::pair<int32_t, int32_t>> pairs;  // (smpl vertex, smplx vertex)
  for (size_t v = 0; v < corr.size(); ++v)
    if (corr[v] >= 0) pairs.emplace_back(int32_t(v), corr[v]);
  std::vector<float> tj(N * kFitJoints * 3), tv(N * pairs.size() * 3), buf_v(std::max(Vs, Vx) * 3), buf_j(kNumJoints * 3);
  for (size_t f = 0; f < N; ++f) {
    smpl_lbs.forward(smpl_frames[f], buf_v.data(), buf_j.data(), nullptr);
    std::copy(buf_j.begin(), buf_j.begin() + kFitJoints * 3, tj.begin() + long(f * kFitJoints * 3));
    for (size_t k = 0; k < pairs.size(); ++k)
      for (int c = 0; c < 3; ++c) tv[(f * pairs.size() + k) * 3 + size_t(c)] = buf_v[size_t(pairs[k].first) * 3 + size_t(c)];
  }

  // Parameters: per-frame pose (66) and transl (3), shared betas.
  std::vector<float> pose(N * kFitPose), transl(N * 3), betas(size_t(nb), 0.0f);
  if (!init.empty()) {
    for (size_t k = 0; k < size_t(nb) && k < init[0].betas.size(); ++k) betas[k] = init[0].betas[k];
    for (size_t f = 0; f < N; ++f) {
      std::copy(init[f].pose.begin(), init[f].pose.begin() + kFitPose, pose.begin() + long(f * kFitPose));
      std::copy(init[f].transl.begin(), init[f].transl.end(), transl.begin() + long(f * 3));
    }
  } else {
    SmplxParams rest;
    lbs.forward(rest, buf_v.data(), buf_j.data(), nullptr);  // buf_j[0..2]: rest pelvis at betas 0
    for (size_t f = 0; f < N; ++f) {
      std::copy(smpl_frames[f].pose.begin(), smpl_frames[f].pose.begin() + kFitPose, pose.begin() + long(f * kFitPose));
      for (int c = 0; c < 3; ++c) transl[f * 3 + size_t(c)] = tj[f * kFitJoints * 3 + size_t(c)] - buf_j[size_t(c)];
    }
  }
  const std::vector<float> pose0 = pose;

  Adam adam;
  const int gp = adam.add_group("pose", int64_t(pose.size()), opt.lr_pose, 3);
  const int gt = adam.add_group("transl", int64_t(transl.size()), opt.lr_transl, 3);
  const int gb = nb > 0 ? adam.add_group("betas", nb, opt.lr_betas) : -1;
  auto schedule = [&](double lr) {
    LogLinearLr s;
    s.lr_init = lr;
    s.lr_final = lr * opt.lr_final_factor;
    s.max_steps = opt.iterations;
    return s;
  };
  const LogLinearLr sp = schedule(opt.lr_pose), st = schedule(opt.lr_transl), sb = schedule(opt.lr_betas);

  std::vector<float> g_pose(pose.size()), g_transl(transl.size()), g_betas(static_cast<size_t>(nb));
  std::vector<float> d_verts(Vx * 3), d_joints(kNumJoints * 3);
  std::vector<float> verts(Vx * 3), joints(kNumJoints * 3);
  LbsCache<float> cache;
  SmplFitResult out;
  out.frames.resize(N);
  auto frame_params = [&](size_t f) {
    SmplxParams& p = out.frames[f];
    p = SmplxParams{};
    std::copy(pose.begin() + long(f * kFitPose), pose.begin() + long((f + 1) * kFitPose), p.pose.begin());
    for (int c = 0; c < 3; ++c) p.transl[size_t(c)] = transl[f * 3 + size_t(c)];
    p.betas = betas;
    return p;
  };
  // Residuals (mm) of the current parameters; also the gradients when `grad` is set.
  auto evaluate = [&](bool grad) {
    out.joint_mm.assign(N, 0.0);
    out.vertex_mm.assign(pairs.empty() ? 0 : N, 0.0);
    std::fill(g_pose.begin(), g_pose.end(), 0.0f);
    std::fill(g_transl.begin(), g_transl.end(), 0.0f);
    std::fill(g_betas.begin(), g_betas.end(), 0.0f);
    for (size_t f = 0; f < N; ++f) {
      const SmplxParams& p = frame_params(f);
      lbs.forward(p, verts.data(), joints.data(), grad ? &cache : nullptr);
      std::fill(d_joints.begin(), d_joints.end(), 0.0f);
      for (int j = 0; j < kFitJoints; ++j) {
        double d2 = 0;
        for (int c = 0; c < 3; ++c) {
          const float e = joints[size_t(3 * j + c)] - tj[(f * kFitJoints + size_t(j)) * 3 + size_t(c)];
          d_joints[size_t(3 * j + c)] = 2.0f * e / float(kFitJoints * N);
          d2 += double(e) * e;
        }
        out.joint_mm[f] += 1000.0 * std::sqrt(d2) / kFitJoints;
      }
      for (size_t k = 0; k < pairs.size(); ++k) {
        double d2 = 0;
        for (int c = 0; c < 3; ++c) {
          const size_t xi = size_t(pairs[k].second) * 3 + size_t(c);
          const float e = verts[xi] - tv[(f * pairs.size() + k) * 3 + size_t(c)];
          d_verts[xi] = 2.0f * e / float(pairs.size() * N);
          d2 += double(e) * e;
        }
        out.vertex_mm[f] += 1000.0 * std::sqrt(d2) / double(pairs.size());
      }
      if (!grad) continue;
      SmplxGrad<float> g = lbs.make_grad(p);
      lbs.backward(p, cache, pairs.empty() ? nullptr : d_verts.data(), d_joints.data(), g);
      for (int k = 0; k < kFitPose; ++k) {
        const size_t i = f * kFitPose + size_t(k);
        g_pose[i] = g.pose[size_t(k)] + (k >= 3 ? float(2 * prior / double(N)) * (pose[i] - pose0[i]) : 0.0f);
      }
      for (int c = 0; c < 3; ++c) g_transl[f * 3 + size_t(c)] = g.transl[size_t(c)];
      for (int k = 0; k < nb; ++k) g_betas[size_t(k)] += g.betas[size_t(k)];
    }
  };
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / double(v.size());
  };
  for (int it = 0; it < opt.iterations; ++it) {
    evaluate(true);
    if (opt.progress && (it % 50 == 0))
      std::printf("smpl fit: iteration %d/%d, mean joint residual %.2f mm%s\n", it, opt.iterations, mean(out.joint_mm),
                  pairs.empty() ? "" : (", vertex residual " + std::to_string(mean(out.vertex_mm)).substr(0, 6) + " mm").c_str());
    adam.set_lr(gp, sp(it));
    adam.set_lr(gt, st(it));
    adam.step(gp, pose.data(), g_pose.data());
    adam.step(gt, transl.data(), g_transl.data());
    if (gb >= 0) {
      adam.set_lr(gb, sb(it));
      adam.step(gb, betas.data(), g_betas.data());
    }
  }
  evaluate(false);
  for (size_t f = 0; f < N; ++f) frame_params(f);
  return out;
}

}  // namespace haha
