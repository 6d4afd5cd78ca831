// Stage 3: learned filtering of the Gaussians over the frozen textured mesh, and pruning.
#include "train/evaluate.h"
#include "train/trainer_impl.h"

namespace haha {

bool Trainer::Impl::step3(LossTerms& terms, std::string& event) {
  const int n = g.size(), B = cfg.batch;
  const LossWeights w = effective(3);
  const float inv_b = 1.0f / float(B);
  activate(g, float(cfg.scale_max), act);
  d_color.assign(3 * size_t(n), 0.0f);
  d_opacity.assign(size_t(n), 0.0f);
  for (int b = 0; b < B; ++b) {
    const int64_t k = int64_t(step) * B + b;
    const int fi = frame_of(3, k);
    float bg[3];
    background(3, k, bg);
    MeshCache& m = mesh_of(fi);
    const MeshLayerView layer{m.depth.data(), m.color.data(), m.mask.data()};
    const GaussianSetView gv = gaussian_view();
    AvatarRenderRequest req;
    req.camera = &in.frames[size_t(fi)].camera;
    const BodyTopology topology = topology_of(body);
    req.body = &topology;
    req.verts = frame_verts[size_t(fi)].data();
    req.face_scale_divisor = float(cfg.face_scale_divisor);
    req.gaussians = &gv;
    req.mesh_layer = &layer;
    req.depth_margin = float(cfg.s3.depth_margin);
    for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
    render_avatar(req, rbuf);
    prepare_ground_truth(fi, bg);
    d_image.assign(3 * size_t(P), 0.0f);
    place_lpips_crop(3, k, fi);
    image_loss(rbuf.image.data(), gt.data(), H, W, nullptr, w, lctx, d_image.data(), inv_b, terms);
    const float* d_alpha_ptr = nullptr;
    if (w.dice > 0) {
      sil.resize(size_t(P));
      d_sil.assign(size_t(P), 0.0f);
      silhouette_union(m.mask.data(), rbuf.alpha.data(), P, sil.data());
      const double v = dice_loss(sil.data(), in.frames[size_t(fi)].mask.data(), P, d_sil.data(), float(w.dice * inv_b));
      terms.dice += v * inv_b;
      terms.total += w.dice * v * inv_b;
      d_alpha.resize(size_t(P));
      silhouette_union_backward(m.mask.data(), d_sil.data(), P, d_alpha.data());
      d_alpha_ptr = d_alpha.data();
    }
    if (b == 0 && w.knn > 0 && n > 1) {
      if (knn_idx.size() != size_t(n) * cfg.s1.knn_k) update_knn(rbuf.means.data());
      KnnRegInputs<float> ki;
      ki.n = n;
      ki.opacity = act.opacity.data();
      ki.color = act.color.data();
      KnnRegGrads<float> kg;
      kg.opacity = d_opacity.data();
      kg.color = d_color.data();
      const double v = knn_reg(ki, knn_idx.data(), cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
      terms.knn += v;
      terms.total += w.knn * v;
    }
    AvatarRenderGrads gr;
    gr.color = d_color.data();
    gr.opacity = d_opacity.data();
    if (pruning_by_cost()) {
      gr.removal_cost = removal_cost.data();
      removal_frames += 1;
    }
    render_avatar_backward(req, rbuf, d_image.data(), d_alpha_ptr, nullptr, gr);
  }
  if (w.opacity > 0 && n > 0) {
    const double v = opacity_reg(act.opacity.data(), n, cfg.s3.opacity_mode, d_opacity.data(), float(w.opacity));
    terms.opacity += v;
    terms.total += w.opacity * v;
  }
  d_color_logit.resize(3 * size_t(n));
  d_opacity_logit.resize(size_t(n));
  activation_backward(act, float(cfg.scale_max), n, nullptr, d_color.data(), d_opacity.data(), nullptr,
                      d_color_logit.data(), d_opacity_logit.data());
  if (hook) hook(3, d_opacity_logit);
  if (!std::isfinite(terms.total) || !finite_all(d_opacity_logit) || !finite_all(d_color_logit)) return false;
  adam.step(adam.group("opacity"), g.opacity_logit.data(), d_opacity_logit.data());
  adam.step(adam.group("color"), g.color_logit.data(), d_color_logit.data());
  after_update(3, event);
  return true;
}

// Deletes the Gaussians under the opacity threshold and, with s3.prune_cost, those whose
// deletion would change the frames rendered since the last prune less than that.
void Trainer::Impl::prune(std::string& event) {
  const int before = g.size();
  const float thr = logit(float(cfg.s3.prune_threshold));
  std::vector<uint8_t> keep(static_cast<size_t>(before));
  for (int i = 0; i < before; ++i)
    keep[size_t(i)] = cfg.s3.prune_threshold <= 0 || g.opacity_logit[size_t(i)] >= thr;
  int by_cost = 0;
  if (pruning_by_cost() && removal_frames > 0 && removal_cost.size() == size_t(before)) {
    const double min_sum = cfg.s3.prune_cost * 1e-6 * double(P) * removal_frames;
    for (int i = 0; i < before; ++i)
      if (keep[size_t(i)] && double(removal_cost[size_t(i)]) < min_sum) {
        keep[size_t(i)] = 0;
        ++by_cost;
      }
  }
  const std::vector<int64_t> idx = indices_where(keep);
  if (int(idx.size()) == before) {
    reset_removal_cost();
    return;
  }
  select(g, idx);
  adam.reindex(adam.group("opacity"), idx);
  adam.reindex(adam.group("color"), idx);
  knn_idx.clear();
  reset_removal_cost();
  event += (event.empty() ? "" : "; ") + std::string("prune ") + std::to_string(before) + " -> " + std::to_string(g.size());
  if (by_cost > 0) event += " (" + std::to_string(by_cost) + " by image cost)";
}

// ---- where the filtering stops (train/filter_stop.h) ----

void Trainer::Impl::fit_validation_poses(std::string& event) {
  if (!cfg.s3.validation_tto || cfg.eval_tto_steps <= 0) return;
  const Avatar a = make_avatar(g);  // stage 1's Gaussians over the texture: the naive merge
  EvalOptions opt = eval_options_of(cfg);
  opt.premultiplied = in.premultiplied;
  std::vector<TrainFrame> views = in.validation;
  for (TrainFrame& f : views) {
    f.params.betas = betas;
    if (f.params.expression.size() > size_t(body.num_expr)) f.params.expression.resize(size_t(body.num_expr));
  }
  const VariantEval r = evaluate_variant(EvalVariant{"naive merge", &a, true, true}, views, opt);
  double before = 0, after = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    SmplxParams& p = in.validation[i].params;
    p.pose = r.poses[i].pose;
    p.transl = r.poses[i].transl;
    before += r.frames[i].tto_loss_start;
    after += r.frames[i].tto_loss_end;
  }
  char b[128];
  std::snprintf(b, sizeof b, "validation poses fitted (%d steps): loss %.4f -> %.4f", cfg.eval_tto_steps,
                before / double(views.size()), after / double(views.size()));
  event += (event.empty() ? "" : "; ") + std::string(b);
}

double Trainer::Impl::validation_psnr() {
  activate(g, float(cfg.scale_max), act);
  const GaussianSetView gv = gaussian_view();
  const BodyTopology topology = topology_of(body);
  std::vector<float> posed(3 * size_t(body.num_verts)), truth;
  const float black[3] = {0, 0, 0};
  double sum = 0;
  for (const TrainFrame& f : in.validation) {
    SmplxParams p = f.params;
    p.betas = betas;
    if (p.expression.size() > size_t(body.num_expr)) p.expression.resize(size_t(body.num_expr));
    lbs.forward(p, posed.data(), nullptr, nullptr);
    raster_mesh_layer(f.camera, posed.data(), scratch_cache);
    scratch_cache.ready = false;  // not a training frame's cache
    const MeshLayerView layer{scratch_cache.depth.data(), scratch_cache.color.data(), scratch_cache.mask.data()};
    AvatarRenderRequest req;
    req.camera = &f.camera;
    req.body = &topology;
    req.verts = posed.data();
    req.face_scale_divisor = float(cfg.face_scale_divisor);
    req.gaussians = &gv;
    req.mesh_layer = &layer;
    req.depth_margin = float(cfg.s3.depth_margin);
    render_avatar(req, rbuf);
    const int np = f.camera.width * f.camera.height;
    truth.resize(3 * size_t(np));
    composite_ground_truth(f.rgb.data(), f.mask.data(), np, in.premultiplied, black, truth.data());
    sum += psnr(rbuf.image.data(), truth.data(), f.camera.height, f.camera.width);
  }
  return sum / double(in.validation.size());
}

void Trainer::Impl::score_filter(int done_steps, std::string& event) {
  const double v = validation_psnr();
  stop.observe(done_steps, v, g);
  char b[96];
  std::snprintf(b, sizeof b, "validation %.2f dB at %d Gaussians", v, g.size());
  event += (event.empty() ? "" : "; ") + std::string(b);
}

void Trainer::Impl::finish_filtering(std::string& event) {
  if (stop.points().empty()) return;
  const FilterStopPoint& p = stop.points()[size_t(stop.chosen())];
  if (const GaussianParams* c = stop.chosen_gaussians()) g = *c;
  knn_idx.clear();
  char b[128];
  std::snprintf(b, sizeof b, "filtering ends at step %d: %d Gaussians, validation %.2f dB", p.step, p.gaussians, p.psnr);
  event += (event.empty() ? "" : "; ") + std::string(b);
}

}  // namespace haha
