// The trainer state in and out: checkpoints and the trained avatar.
#include "train/trainer_impl.h"

namespace haha {

void Trainer::Impl::put_gaussians(TrainCheckpoint& ck, const std::string& pre, const GaussianParams& x) {
  ck.i32[pre + "face"] = x.face;
  ck.f32[pre + "offset"] = x.offset;
  ck.f32[pre + "rotation"] = x.rotation;
  ck.f32[pre + "scale_logit"] = x.scale_logit;
  ck.f32[pre + "color_logit"] = x.color_logit;
  ck.f32[pre + "opacity_logit"] = x.opacity_logit;
}

TrainCheckpoint Trainer::Impl::save() const {
  TrainCheckpoint ck;
  ck.i32["meta.version"] = {1};
  ck.i32["meta.stage"] = {stage};
  ck.i32["meta.step"] = {step};
  ck.i32["meta.num_frames"] = {nf};
  ck.i32["meta.texture_size"] = {tex_size};
  ck.i32["meta.skipped"] = {int32_t(skipped)};
  ck.i32["meta.nan_streak"] = {nan_streak};
  ck.f64["time.seconds"] = {seconds[0], seconds[1], seconds[2]};
  if (stage == 3 && validating()) {
    stop.save(ck.f64);
    for (const char* k : {"within", "best"})
      if (stop.has_kept(k)) put_gaussians(ck, std::string("stop.") + k + ".", stop.kept(k));
  }
  put_gaussians(ck, "g.", g);
  if (have_s1) put_gaussians(ck, "s1g.", g_s1);
  ck.f32["betas"] = betas;
  std::vector<float> pose, transl;
  for (const SmplxParams& p : params) {
    pose.insert(pose.end(), p.pose.begin(), p.pose.end());
    transl.insert(transl.end(), p.transl.begin(), p.transl.end());
  }
  ck.f32["pose"] = pose;
  ck.f32["transl"] = transl;
  if (validating()) {  // their poses were fitted before training; a resumed run does not fit them again
    std::vector<float> vpose, vtransl;
    for (const TrainFrame& f : in.validation) {
      vpose.insert(vpose.end(), f.params.pose.begin(), f.params.pose.end());
      vtransl.insert(vtransl.end(), f.params.transl.begin(), f.params.transl.end());
    }
    ck.f32["validation.pose"] = vpose;
    ck.f32["validation.transl"] = vtransl;
  }
  if (!texture.empty()) ck.f32["texture"] = texture;
  if (!coverage.empty()) ck.f32["mesh_coverage"] = coverage;
  for (const auto& [key, v] : adam.state()) ck.f32[key] = v;
  if (stage == 1) {
    ck.f32["densify.grad_accum"] = grad_accum;
    ck.f32["densify.count"] = grad_count;
  }
  if (stage == 3 && !removal_cost.empty()) {
    ck.f32["prune.removal_cost"] = removal_cost;
    ck.f64["prune.removal_frames"] = {removal_frames};
  }
  ck.i32["knn.sets"] = knn_idx;
  return ck;
}

void Trainer::Impl::load(const TrainCheckpoint& ck, const std::string& where) {
  auto geti = [&](const std::string& k) -> const std::vector<int32_t>& {
    auto it = ck.i32.find(k);
    if (it == ck.i32.end()) fail(where, k + ": missing");
    return it->second;
  };
  auto getf = [&](const std::string& k) -> const std::vector<float>& {
    auto it = ck.f32.find(k);
    if (it == ck.f32.end()) fail(where, k + ": missing");
    return it->second;
  };
  auto scalar = [&](const std::string& k) {
    const auto& v = geti(k);
    if (v.size() != 1) fail(where, k + ": expected one value");
    return v[0];
  };
  if (scalar("meta.version") != 1) fail(where, "meta.version: unsupported checkpoint version");
  if (scalar("meta.num_frames") != nf)
    fail(where, "meta.num_frames: checkpoint has " + std::to_string(scalar("meta.num_frames")) +
                    " training frames, the dataset " + std::to_string(nf));
  const int st = scalar("meta.stage"), sp = scalar("meta.step");
  if (st < 1 || st > 4 || sp < 0 || (st <= 3 && sp > stage_steps(st)))
    fail(where, "meta.stage/meta.step: stage " + std::to_string(st) + " step " + std::to_string(sp) +
                    " does not fit the configured schedule");
  // The texture grows over stage 2's levels: any of their sizes (the config's when it has none).
  const int ts = scalar("meta.texture_size");
  bool ts_ok = ts == cfg.s2.texture_size;
  for (int l = 0; l < levels[1].num_levels(); ++l) ts_ok = ts_ok || ts == texture_side(l);
  if (!ts_ok) fail(where, "meta.texture_size: differs from the config's s2.texture_size and its levels");
  auto read_g = [&](const std::string& pre) {
    GaussianParams x;
    x.face = geti(pre + "face");
    const size_t n = x.face.size();
    auto sized = [&](const std::string& k, size_t stride) {
      const auto& v = getf(pre + k);
      if (v.size() != n * stride) fail(where, pre + k + ": expected " + std::to_string(n * stride) + " values");
      if (!finite_all(v)) fail(where, pre + k + ": non-finite values");
      return v;
    };
    x.offset = sized("offset", 3);
    x.rotation = sized("rotation", 4);
    x.scale_logit = sized("scale_logit", 3);
    x.color_logit = sized("color_logit", 3);
    x.opacity_logit = sized("opacity_logit", 1);
    for (int32_t f : x.face)
      if (f < 0 || f >= body.num_faces) fail(where, pre + "face: face index outside the body model");
    return x;
  };
  GaussianParams ng = read_g("g.");
  const bool ns1 = ck.i32.count("s1g.face") > 0;
  GaussianParams ng1 = ns1 ? read_g("s1g.") : GaussianParams{};
  const auto& nb = getf("betas");
  if (nb.size() != betas.size()) fail(where, "betas: expected " + std::to_string(betas.size()) + " values");
  const auto& pose = getf("pose");
  const auto& transl = getf("transl");
  if (pose.size() != size_t(nf) * kNumPoseValues || transl.size() != size_t(nf) * 3)
    fail(where, "pose/transl: sizes do not match the training frames");
  const size_t nv = in.validation.size();
  const std::vector<float>* vpose = nullptr;
  const std::vector<float>* vtransl = nullptr;
  if (validating()) {
    vpose = &getf("validation.pose");
    vtransl = &getf("validation.transl");
    if (vpose->size() != nv * kNumPoseValues || vtransl->size() != nv * 3 || !finite_all(*vpose) || !finite_all(*vtransl))
      fail(where, "validation.pose/transl: do not match the validation frames");
  }
  std::vector<float> tex;
  if (ck.f32.count("texture")) {
    tex = getf("texture");
    if (tex.size() != size_t(ts) * ts * 3) fail(where, "texture: wrong size");
  }
  std::vector<float> cov;
  if (ck.f32.count("mesh_coverage")) {
    cov = getf("mesh_coverage");
    if (cov.size() != size_t(body.num_verts)) fail(where, "mesh_coverage: does not match the body's vertices");
    for (float c : cov)
      if (!(c >= 0.0f && c <= 1.0f)) fail(where, "mesh_coverage: values must be in [0, 1]");
  }
  // Commit.
  stage = st;
  step = sp;
  g = std::move(ng);
  have_s1 = ns1;
  g_s1 = std::move(ng1);
  betas = nb;
  for (int i = 0; i < nf; ++i) {
    SmplxParams& p = params[size_t(i)];
    for (int q = 0; q < kNumPoseValues; ++q) p.pose[size_t(q)] = pose[size_t(i) * kNumPoseValues + size_t(q)];
    for (int q = 0; q < 3; ++q) p.transl[size_t(q)] = transl[size_t(i) * 3 + size_t(q)];
  }
  for (size_t i = 0; vpose && i < nv; ++i) {
    SmplxParams& p = in.validation[i].params;
    std::copy_n(vpose->begin() + std::ptrdiff_t(i * kNumPoseValues), kNumPoseValues, p.pose.begin());
    std::copy_n(vtransl->begin() + std::ptrdiff_t(i * 3), 3, p.transl.begin());
  }
  texture = std::move(tex);
  tex_size = ts;
  coverage = std::move(cov);
  skipped = scalar("meta.skipped");
  nan_streak = scalar("meta.nan_streak");
  auto it = ck.f64.find("time.seconds");
  if (it != ck.f64.end() && it->second.size() == 3) seconds = {it->second[0], it->second[1], it->second[2]};
  if (stage <= 3) {
    begin_stage(stage);
    if (stage == 3) learn_coverage(resume_event);  // a run from before s2.coverage, resumed with it on
    adam.load_state(ck.f32, where);
    if (stage == 3 && validating()) {
      stop.load(ck.f64, where);
      for (const char* k : {"within", "best"})
        if (stop.has_kept(k)) stop.kept(k) = read_g(std::string("stop.") + k + ".");
    }
    if (stage == 3 && pruning_by_cost() && ck.f32.count("prune.removal_cost")) {  // else since the resume only
      std::vector<float> rc = getf("prune.removal_cost");
      const auto fr = ck.f64.find("prune.removal_frames");
      if (rc.size() != size_t(g.size()) || fr == ck.f64.end() || fr->second.size() != 1 ||
          !(std::isfinite(fr->second[0]) && fr->second[0] >= 0))
        fail(where, "prune.*: sizes do not match the Gaussians");
      for (float c : rc)
        if (!(std::isfinite(c) && c >= 0.0f)) fail(where, "prune.removal_cost: values must be finite and >= 0");
      removal_cost = std::move(rc);
      removal_frames = fr->second[0];
    }
    if (stage == 1) {
      grad_accum = getf("densify.grad_accum");
      grad_count = getf("densify.count");
      if (grad_accum.size() != size_t(g.size()) || grad_count.size() != size_t(g.size()))
        fail(where, "densify.*: sizes do not match the Gaussians");
    }
    knn_idx = geti("knn.sets");
    if (!knn_idx.empty() && knn_idx.size() != size_t(g.size()) * cfg.s1.knn_k)
      fail(where, "knn.sets: size does not match the Gaussians");
  }
}

Avatar Trainer::Impl::make_avatar(const GaussianParams& x) const {
  Avatar a;
  a.body = body;
  a.betas = betas;
  a.face_scale_divisor = float(cfg.face_scale_divisor);
  a.depth_margin = float(cfg.s3.depth_margin);
  a.texture.width = a.texture.height = texture.empty() ? 0 : tex_size;
  a.texture.rgb = texture;
  a.mesh_coverage = coverage;
  a.gaussians = to_bound(x, float(cfg.scale_max));
  return a;
}

}  // namespace haha
