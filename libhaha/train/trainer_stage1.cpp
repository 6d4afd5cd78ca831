// Stage 1: the Gaussians with per-frame pose refinement (no mesh), and densification.
#include "train/trainer_impl.h"

namespace haha {

// The KNN regulariser (docs/method.md section 3) on the posed centres of the last render;
// its gradient on the centres is returned (added in the render's backward), the others
// are added to the parameter gradients here.
const float* Trainer::Impl::knn_term(const LossWeights& w, bool need_knn, LossTerms& terms) {
  const int n = g.size();
  if (need_knn) update_knn(rbuf.means.data());
  d_means_extra.assign(3 * size_t(n), 0.0f);
  rot_unit.resize(4 * size_t(n));
  d_rot_unit.assign(4 * size_t(n), 0.0f);
  for (int i = 0; i < n; ++i) normalize_quat(&g.rotation[4 * size_t(i)], &rot_unit[4 * size_t(i)]);
  KnnRegInputs<float> ki;
  ki.n = n;
  ki.position = rbuf.means.data();
  ki.rotation = rot_unit.data();
  ki.scale = act.scale.data();
  ki.color = act.color.data();
  KnnRegGrads<float> kg;
  kg.position = d_means_extra.data();
  kg.rotation = d_rot_unit.data();
  kg.scale = d_scale.data();
  kg.color = d_color.data();
  const double v = knn_reg(ki, knn_idx.data(), cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
  terms.knn += v;
  terms.total += w.knn * v;
  return d_means_extra.data();
}

// Pose refinement: the frame's SMPL-X gradient from the posed-vertex gradient, added to its
// body / fine groups (and the shared betas). d_verts already holds the batch mean's 1/B
// (the image gradient was scaled by it), so nothing is divided here.
void Trainer::Impl::accumulate_pose_grad(int fi) {
  const SmplxParams fp = frame_params(fi);
  SmplxGrad<float> sg = lbs.make_grad(fp);
  lbs.backward(fp, lcache, d_verts.data(), nullptr, sg);
  add_pose_grad(fi, sg);
}

// Adds one frame's SMPL-X gradient to its pose groups and the shared betas (both devices).
void Trainer::Impl::add_pose_grad(int fi, const SmplxGrad<float>& sg) {
  std::vector<float>& db = d_frame_body[size_t(fi)];
  std::vector<float>& dfn = d_frame_fine[size_t(fi)];
  if (!frame_touched[size_t(fi)]) {
    std::fill(db.begin(), db.end(), 0.0f);
    std::fill(dfn.begin(), dfn.end(), 0.0f);
    frame_touched[size_t(fi)] = 1;
  }
  pose_to_groups(sg, db.data(), dfn.data(), /*accumulate=*/true);
  for (size_t q = 0; q < betas.size(); ++q) d_betas[q] += sg.betas[q];
}

bool Trainer::Impl::pose_grads_finite() const {
  if (!finite_all(d_betas)) return false;
  for (int i = 0; i < nf; ++i)
    if (frame_touched[size_t(i)] && !(finite_all(d_frame_body[size_t(i)]) && finite_all(d_frame_fine[size_t(i)])))
      return false;
  return true;
}

// Adam on the Gaussians, and on the refined poses and betas (gradients of the batch mean).
void Trainer::Impl::update_stage1() {
  const LogLinearLr sched{cfg.s1.lr_offset_init, cfg.s1.lr_offset_final, cfg.s1.steps};
  adam.set_lr(adam.group("offset"), sched(step));
  adam.step(adam.group("offset"), g.offset.data(), d_offset.data());
  adam.step(adam.group("rotation"), g.rotation.data(), d_rotation.data());
  adam.step(adam.group("scale"), g.scale_logit.data(), d_scale_logit.data());
  adam.step(adam.group("color"), g.color_logit.data(), d_color_logit.data());
  update_pose();
}

// Adam on the refined poses and betas (host values on every device: LBS takes them from
// the host).
void Trainer::Impl::update_pose() {
  if (cfg.s1.refine_pose) {
    // Decayed pose rates (s1.lr.pose_final): the same factor for every pose group.
    double f = 1;
    if (cfg.s1.lr_pose_final > 0 && cfg.s1.lr_pose > 0)
      f = LogLinearLr{cfg.s1.lr_pose, cfg.s1.lr_pose_final, cfg.s1.steps}(step) / cfg.s1.lr_pose;
    if (cfg.s1.lr_pose_level_exp > 0 && level_stage == 1)
      f *= std::pow(std::ldexp(1.0, level - (levels[0].num_levels() - 1)), cfg.s1.lr_pose_level_exp);
    adam.set_lr(adam.group("betas"), f * cfg.s1.lr_pose * cfg.s1.lr_betas_scale);
    if (pose_hook) pose_hook("betas", d_betas);  // exactly what Adam receives
    adam.step(adam.group("betas"), betas.data(), d_betas.data());
    for (int i = 0; i < nf; ++i) {
      if (!frame_touched[size_t(i)]) continue;  // a frame drawn twice in one batch counts twice
      std::vector<float> body_vals(kPoseBodyGroup), fine_vals(kPoseFineGroup);
      SmplxParams& p = params[size_t(i)];
      pose_to_groups(p, body_vals.data(), fine_vals.data());
      if (pose_hook) {
        pose_hook("frame" + std::to_string(i) + ".body", d_frame_body[size_t(i)]);
        pose_hook("frame" + std::to_string(i) + ".fine", d_frame_fine[size_t(i)]);
      }
      const int gb = adam.group("frame" + std::to_string(i) + ".body");
      const int gf = adam.group("frame" + std::to_string(i) + ".fine");
      adam.set_lr(gb, f * cfg.s1.lr_pose);
      adam.set_lr(gf, f * cfg.s1.lr_pose_fine);
      adam.step(gb, body_vals.data(), d_frame_body[size_t(i)].data());
      adam.step(gf, fine_vals.data(), d_frame_fine[size_t(i)].data());
      groups_to_pose(body_vals.data(), fine_vals.data(), p);
    }
  }
}

bool Trainer::Impl::step1(LossTerms& terms, std::string& event) {
  const int n = g.size(), B = cfg.batch;
  const LossWeights w = effective(1);
  activate(g, float(cfg.scale_max), act);
  d_offset.assign(3 * size_t(n), 0.0f);
  d_rotation.assign(4 * size_t(n), 0.0f);
  d_scale.assign(3 * size_t(n), 0.0f);
  d_color.assign(3 * size_t(n), 0.0f);
  d_betas.assign(betas.size(), 0.0f);
  std::fill(frame_touched.begin(), frame_touched.end(), 0);
  const float inv_b = 1.0f / float(B);
  const bool need_knn = w.knn > 0 && n > 1 &&
                        (knn_idx.size() != size_t(n) * cfg.s1.knn_k || step % cfg.s1.knn_every == 0);
  for (int b = 0; b < B; ++b) {
    const int64_t k = int64_t(step) * B + b;
    const int fi = frame_of(1, k);
    float bg[3];
    background(1, k, bg);
    pose_frame(fi, cfg.s1.refine_pose);
    const GaussianSetView gv = gaussian_view();
    AvatarRenderRequest req;
    req.camera = &in.frames[size_t(fi)].camera;
    const BodyTopology topology = topology_of(body);
    req.body = &topology;
    req.verts = verts.data();
    req.face_scale_divisor = float(cfg.face_scale_divisor);
    req.gaussians = &gv;
    for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
    render_avatar(req, rbuf);
    prepare_ground_truth(fi, bg);
    d_image.assign(3 * size_t(P), 0.0f);
    place_lpips_crop(1, k, fi);
    image_loss(rbuf.image.data(), gt.data(), H, W, nullptr, w, lctx, d_image.data(), inv_b, terms);
    const float* d_alpha_ptr = nullptr;
    if (w.dice > 0) {
      d_alpha.assign(size_t(P), 0.0f);
      const double v = dice_loss(rbuf.alpha.data(), in.frames[size_t(fi)].mask.data(), P, d_alpha.data(),
                                 float(w.dice * inv_b));
      terms.dice += v * inv_b;
      terms.total += w.dice * v * inv_b;
      d_alpha_ptr = d_alpha.data();
    }
    // The KNN regulariser on the posed centres, once per batch.
    const float* d_means_ptr = b == 0 && w.knn > 0 && n > 1 ? knn_term(w, need_knn, terms) : nullptr;
    d_verts.assign(3 * size_t(body.num_verts), 0.0f);
    AvatarRenderGrads gr;
    gr.verts = cfg.s1.refine_pose ? d_verts.data() : nullptr;
    gr.offset = d_offset.data();
    gr.rotation = d_rotation.data();
    gr.scale = d_scale.data();
    gr.color = d_color.data();
    gr.means2d_norm_accum = grad_accum.data();
    // 3DGS's threshold is in NDC units: the pixel-space gradient times half the image size,
    // each axis its own; times B, since d_image carries the batch mean's 1/B and the
    // statistic is a per-view gradient (the same frame gives the same value at any batch).
    gr.means2d_norm_scale[0] = 0.5f * float(W) * float(B);
    gr.means2d_norm_scale[1] = 0.5f * float(H) * float(B);
    render_avatar_backward(req, rbuf, d_image.data(), d_alpha_ptr, d_means_ptr, gr);
    for (int i = 0; i < n; ++i)
      if (rbuf.raster.radii[size_t(i)] > 0) grad_count[size_t(i)] += 1.0f;
    if (cfg.s1.refine_pose) accumulate_pose_grad(fi);
  }
  if (w.stretch > 0) {  // once per batch, on the parameters (not a per-frame term)
    const double v = stretch_reg(g.face.data(), face_stretch.data(), g.offset.data(), act.scale.data(), n,
                                 d_offset.data(), d_scale.data(), float(w.stretch));
    terms.stretch += v;
    terms.total += w.stretch * v;
  }
  if (!rot_unit.empty() && !d_rot_unit.empty() && w.knn > 0 && n > 1)
    for (int i = 0; i < n; ++i) {
      float dr[4];
      normalize_quat_backward(&g.rotation[4 * size_t(i)], &d_rot_unit[4 * size_t(i)], dr);
      for (int c = 0; c < 4; ++c) d_rotation[4 * size_t(i) + c] += dr[c];
    }
  // The batch mean of the image terms is in d_image's scale; the KNN gradient was added
  // once; the densification statistic is a sum of per-view gradients (3DGS).
  d_scale_logit.resize(3 * size_t(n));
  d_color_logit.resize(3 * size_t(n));
  activation_backward(act, float(cfg.scale_max), n, d_scale.data(), d_color.data(), nullptr, d_scale_logit.data(),
                      d_color_logit.data(), nullptr);
  if (hook) hook(1, d_offset);
  const bool ok = std::isfinite(terms.total) && finite_all(d_offset) && finite_all(d_rotation) &&
                  finite_all(d_scale_logit) && finite_all(d_color_logit) && pose_grads_finite();
  if (!ok) return false;

  update_stage1();
  after_update(1, event);
  return true;
}

void Trainer::Impl::after_update(int s, std::string& event) {
  const int done_steps = step + 1;  // the completed-step count
  const Stage1Config& s1 = cfg.s1;
  // Densification after the update (3DGS order); pruning every prune_every steps and at the end.
  const bool densify_now = s == 1 && s1.densify_every > 0 && done_steps > s1.densify_from &&
                           done_steps < s1.densify_until && done_steps % s1.densify_every == 0;
  const bool prune_now =
      s == 3 && ((cfg.s3.prune_every > 0 && done_steps % cfg.s3.prune_every == 0) || done_steps == cfg.s3.steps);
  if (!densify_now && !prune_now) return;
  sync_host();
  if (densify_now) densify(event);
  if (prune_now) prune(event);
  if (prune_now && validating()) score_filter(done_steps, event);
  if (dev) dev->upload();
}

void Trainer::Impl::densify(std::string& event) {
  const Stage1Config& s1 = cfg.s1;
  const DensifyPlan plan = plan_densify(g, float(cfg.scale_max), grad_accum, grad_count, s1.densify_grad,
                                       s1.densify_clone_scale, s1.max_gaussians);
  const int before = g.size();
  const DensifyResult r = apply_densify(g, plan, float(cfg.scale_max), s1.densify_split_std, s1.densify_split_div,
                                        hash64(cfg.seed, stream(1, kSplit), uint64_t(step)));
  for (const char* name : {"offset", "rotation", "scale", "color"}) adam.reindex(adam.group(name), r.adam_source);
  knn_idx.clear();
  // Distribution of the statistic (visible Gaussians), to judge the threshold.
  std::vector<float> seen;
  for (size_t i = 0; i < grad_accum.size(); ++i)
    if (grad_count[i] > 0) seen.push_back(grad_accum[i] / grad_count[i]);
  std::sort(seen.begin(), seen.end());
  auto pct = [&](double q) { return seen.empty() ? 0.0 : double(seen[size_t(q * double(seen.size() - 1))]); };
  char buf[192];
  std::snprintf(buf, sizeof buf, "densify %d -> %d (clone %d, split %d; mean grad p50 %.2g p90 %.2g p99 %.2g)", before,
                g.size(), r.cloned, r.split, pct(0.5), pct(0.9), pct(0.99));
  event += (event.empty() ? "" : "; ") + std::string(buf);
  grad_accum.assign(size_t(g.size()), 0.0f);
  grad_count.assign(size_t(g.size()), 0.0f);
}

}  // namespace haha
