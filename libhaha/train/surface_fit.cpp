#include "train/surface_fit.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "body/lbs.h"
#include "core/error.h"
#include "render/avatar_render.h"
#include "render/mesh_antialias.h"
#include "train/adam.h"
#include "train/fit_steps.h"
#include "train/gaussian_params.h"
#include "train/image_loss.h"
#include "train/levels.h"
#include "train/part_clearance.h"
#include "train/silhouette_fit.h"

namespace haha {

std::vector<float> vertex_normals(const float* verts, int num_verts, const int32_t* faces, int num_faces) {
  std::vector<double> acc(3 * size_t(num_verts), 0.0);
  for (int f = 0; f < num_faces; ++f) {
    const int32_t* c = faces + 3 * size_t(f);
    const float* a = verts + 3 * size_t(c[0]);
    const float* b = verts + 3 * size_t(c[1]);
    const float* d = verts + 3 * size_t(c[2]);
    const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double e2[3] = {double(d[0]) - a[0], double(d[1]) - a[1], double(d[2]) - a[2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    for (int k = 0; k < 3; ++k)
      for (int r = 0; r < 3; ++r) acc[3 * size_t(c[k]) + r] += n[r];  // |n| = twice the area
  }
  std::vector<float> out(acc.size(), 0.0f);
  for (int v = 0; v < num_verts; ++v) {
    const double* n = &acc[3 * size_t(v)];
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len > 0)
      for (int r = 0; r < 3; ++r) out[3 * size_t(v) + r] = float(n[r] / len);
  }
  return out;
}

VertexAdjacency vertex_adjacency(const int32_t* faces, int num_faces, int num_verts) {
  std::vector<std::vector<int32_t>> nb{size_t(num_verts)};
  for (int f = 0; f < num_faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = faces[3 * size_t(f) + k], b = faces[3 * size_t(f) + (k + 1) % 3];
      nb[size_t(a)].push_back(b);
      nb[size_t(b)].push_back(a);
    }
  VertexAdjacency adj;
  adj.off.assign(size_t(num_verts) + 1, 0);
  for (int v = 0; v < num_verts; ++v) {
    std::vector<int32_t>& n = nb[size_t(v)];
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
    n.erase(std::remove(n.begin(), n.end(), v), n.end());
    adj.idx.insert(adj.idx.end(), n.begin(), n.end());
    adj.off[size_t(v) + 1] = int32_t(adj.idx.size());
  }
  return adj;
}

template <class T>
T surface_regularizer(const T* h, const VertexAdjacency& adj, double w_laplacian, double w_shrink, T* grad) {
  const int V = int(adj.off.size()) - 1;
  if (V <= 0) return T(0);
  const T inv_v = T(1) / T(V);
  T e = 0;
  for (int v = 0; v < V; ++v) {
    e += T(w_shrink) * inv_v * h[v] * h[v];
    if (grad) grad[v] += T(2 * w_shrink) * inv_v * h[v];
    const int32_t b = adj.off[size_t(v)], n = adj.off[size_t(v) + 1] - b;
    if (n == 0 || w_laplacian == 0) continue;
    T mean = 0;
    for (int32_t k = 0; k < n; ++k) mean += h[adj.idx[size_t(b + k)]];
    mean /= T(n);
    const T r = h[v] - mean;
    e += T(w_laplacian) * inv_v * r * r;
    if (!grad) continue;
    const T g = T(2 * w_laplacian) * inv_v * r;
    grad[v] += g;
    for (int32_t k = 0; k < n; ++k) grad[adj.idx[size_t(b + k)]] -= g / T(n);
  }
  return e;
}
template float surface_regularizer<float>(const float*, const VertexAdjacency&, double, double, float*);
template double surface_regularizer<double>(const double*, const VertexAdjacency&, double, double, double*);

template <class T>
void displace_posed(const T* base, const T* u, const T* h, int num_verts, T* out) {
  for (int v = 0; v < num_verts; ++v)
    for (int r = 0; r < 3; ++r) out[3 * size_t(v) + r] = base[3 * size_t(v) + r] + h[v] * u[3 * size_t(v) + r];
}
template <class T>
void displace_posed_backward(const T* u, const T* d_out, int num_verts, T* d_h) {
  for (int v = 0; v < num_verts; ++v) {
    const size_t i = 3 * size_t(v);
    d_h[v] += u[i] * d_out[i] + u[i + 1] * d_out[i + 1] + u[i + 2] * d_out[i + 2];
  }
}
template void displace_posed<float>(const float*, const float*, const float*, int, float*);
template void displace_posed<double>(const double*, const double*, const double*, int, double*);
template void displace_posed_backward<float>(const float*, const float*, int, float*);
template void displace_posed_backward<double>(const double*, const double*, int, double*);

void posed_normal_directions(const BodyModel& body, const std::vector<Rigid<float>>& skinning, const float* normals,
                             float* u) {
  const int V = body.num_verts;
  for (int v = 0; v < V; ++v) {
    const Vec3<float> n{normals[3 * size_t(v)], normals[3 * size_t(v) + 1], normals[3 * size_t(v) + 2]};
    Vec3<float> acc{};
    const float* w = body.weights.data() + size_t(v) * kNumJoints;
    for (int j = 0; j < kNumJoints; ++j)
      if (w[j] != 0.0f) acc = acc + (skinning[size_t(j)].R * n) * w[j];
    for (int r = 0; r < 3; ++r) u[3 * size_t(v) + r] = acc[r];
  }
}

std::vector<float> outward_bounds(const BodyModel& body, double max_out, double max_held) {
  auto held = [](int j) {
    return j == 7 || j == 8 || j == 10 || j == 11 || j == 20 || j == 21 || j >= kJaw;  // ankles, feet, wrists, face, hands
  };
  std::vector<float> out(size_t(body.num_verts));
  for (int v = 0; v < body.num_verts; ++v) {
    double s = 0;
    for (int j = 0; j < kNumJoints; ++j)
      if (held(j)) s += body.weights[size_t(v) * kNumJoints + size_t(j)];
    s = std::clamp(s, 0.0, 1.0);
    out[size_t(v)] = float(max_out * (1 - s) + max_held * s);
  }
  return out;
}

namespace {

constexpr uint64_t kOrderStream = 0x5f70, kBackgroundStream = 0x5f71;

void check_frames(const std::vector<TrainFrame>& frames) {
  const Camera& c0 = frames[0].camera;
  for (const TrainFrame& f : frames) {
    const size_t P = size_t(f.camera.width) * f.camera.height;
    if (f.camera.width != c0.width || f.camera.height != c0.height) fail(f.name, "clothed surface fit: frames of different sizes");
    if (f.mask.size() != P || f.rgb.size() != 3 * P) fail(f.name, "clothed surface fit: needs the image and its mask");
  }
}

// The adjacency of the garment's faces alone, over all vertices (the body's have none), so
// its smoothness weight is its own.
VertexAdjacency garment_adjacency(const BodyModel& body) {
  if (!body.has_garment()) return vertex_adjacency(nullptr, 0, body.num_verts);
  const int F0 = body.num_body_faces();
  return vertex_adjacency(body.faces.data() + 3 * size_t(F0), body.num_faces - F0, body.num_verts);
}

bool all_finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// The state of the fit: h with its optimiser and bounds, each frame's bare posed body and
// posed normal directions, the texture (made anew at each level) and the level's frames.
class SurfaceFit {
 public:
  SurfaceFit(const BodyModel& body, const std::vector<TrainFrame>& frames, bool premultiplied,
             const Stage0Config::Surface& opt, uint64_t seed)
      : body_(body), frames_(frames), premultiplied_(premultiplied), opt_(opt), seed_(seed),
        neighbors_(mesh_face_neighbors(body.faces.data(), body.num_faces, body.num_verts)), topology_(topology_of(body)),
        silhouette_(body), adj_(vertex_adjacency(body.faces.data(), body.num_body_faces(), body.num_verts)),
        garment_adj_(garment_adjacency(body)),
        upper_(outward_bounds(body, opt.max_out, opt.max_held)), lower_(size_t(body.num_verts), -float(opt.max_in)) {
    // A garment starts outside the body and only moves out; with garment_only the body stays.
    for (int v = 0; v < body.num_verts; ++v) {
      const bool garment = v >= body.num_body_verts();
      if (garment) upper_[size_t(v)] = float(opt.garment_max_out);
      if (garment || opt.garment_only) lower_[size_t(v)] = 0.0f;
      if (!garment && opt.garment_only) upper_[size_t(v)] = 0.0f;
    }
    topology_.face_neighbors = neighbors_.data();
    schedule_ = make_level_schedule(opt_.levels, opt_.steps, "s0.surface.levels");
    warmup_steps_ = int(std::lround(opt_.warmup * opt_.steps));
    const int V = body.num_verts;
    h_.assign(size_t(V), 0.0f);
    h_adam_.add_group("h", body.num_body_verts(), opt_.lr);
    if (body.has_garment()) h_adam_.add_group("h_garment", V - body.num_body_verts(), opt_.garment_lr);
    pose_frames(video_betas(frames, body.num_shape));
    if (opt_.part_clearance && !opt_.garment_only) hold_parts_apart();
  }

  // One step: returns the data loss (NaN when the step was skipped for a non-finite value).
  double step(int s) {
    enter_level(schedule_.level_of(s));
    const int fi = epoch_draw(seed_, kOrderStream, int(frames_.size()), s);
    const TrainFrame& f = level_frames_[size_t(fi)];
    const int V = body_.num_verts;
    const bool move = s >= warmup_steps_;
    verts_.resize(3 * size_t(V));
    displace_posed(base_[size_t(fi)].data(), dir_[size_t(fi)].data(), h_.data(), V, verts_.data());
    d_verts_.assign(verts_.size(), 0.0f);
    double loss = photo_term(f, s, move);
    if (move && opt_.w_silhouette > 0) loss += silhouette_term(f);
    d_h_.assign(size_t(V), 0.0f);
    displace_posed_backward(dir_[size_t(fi)].data(), d_verts_.data(), V, d_h_.data());
    surface_regularizer(h_.data(), adj_, opt_.w_laplacian, opt_.w_shrink, d_h_.data());
    if (body_.has_garment()) surface_regularizer(h_.data(), garment_adj_, opt_.garment_w_laplacian, 0.0, d_h_.data());
    if (!std::isfinite(loss) || !all_finite(d_texture_) || !all_finite(d_h_)) return NAN;
    tex_adam_.set_lr(0, LogLinearLr{opt_.lr_texture, opt_.lr_texture_final, opt_.steps}(s));
    tex_adam_.step(0, texture_.data(), d_texture_.data());
    for (float& t : texture_) t = std::clamp(t, 0.0f, 1.0f);
    if (move) {
      const int moving = std::max(1, opt_.steps - warmup_steps_);
      h_adam_.set_lr(0, LogLinearLr{opt_.lr, opt_.lr_final, moving}(s - warmup_steps_));
      h_adam_.step(0, h_.data(), d_h_.data());
      if (body_.has_garment()) {  // the garment's own group: the tail of h
        const size_t b = size_t(body_.num_body_verts());
        h_adam_.set_lr(1, LogLinearLr{opt_.garment_lr, opt_.garment_lr_final, moving}(s - warmup_steps_));
        h_adam_.step(1, h_.data() + b, d_h_.data() + b);
      }
      for (int v = 0; v < V; ++v) h_[size_t(v)] = std::clamp(h_[size_t(v)], lower_[size_t(v)], upper_[size_t(v)]);
    }
    return loss;
  }

  SurfaceFitReport report() const {
    SurfaceFitReport r;
    const int V = body_.num_verts;
    r.offsets.resize(3 * size_t(V));
    std::vector<float> mag(static_cast<size_t>(V));
    double sum = 0;
    for (int v = 0; v < V; ++v) {
      for (int k = 0; k < 3; ++k) r.offsets[3 * size_t(v) + k] = h_[size_t(v)] * normals_[3 * size_t(v) + k];
      sum += std::abs(h_[size_t(v)]);
      mag[size_t(v)] = h_[size_t(v)];
    }
    std::sort(mag.begin(), mag.end());
    r.mean_mm = 1e3 * sum / V;
    r.p95_mm = 1e3 * mag[size_t(0.95 * (V - 1))];
    r.max_mm = 1e3 * mag.back();
    r.side = level_frames_.empty() ? 0 : std::max(level_frames_[0].camera.width, level_frames_[0].camera.height);
    r.part_held = part_held_;
    return r;
  }

 private:
  // Each frame's bare posed body and its posed normal directions (the poses stay frozen).
  void pose_frames(const std::vector<float>& betas) {
    const int V = body_.num_verts;
    Lbs<float> lbs(body_);
    SmplxParams rest;
    rest.betas = betas;
    std::vector<float> shaped(3 * size_t(V));
    lbs.forward(rest, shaped.data(), nullptr, nullptr);  // zero pose: the shaped rest body
    normals_ = vertex_normals(shaped.data(), V, body_.faces.data(), body_.num_faces);
    LbsCache<float> cache;
    for (const TrainFrame& f : frames_) {
      SmplxParams p = f.params;
      p.betas = betas;
      base_.emplace_back(3 * size_t(V));
      dir_.emplace_back(3 * size_t(V));
      lbs.forward(p, base_.back().data(), nullptr, &cache);
      posed_normal_directions(body_, cache.skinning, normals_.data(), dir_.back().data());
    }
  }

  // Lowers the body's outward bounds so that no part grows over another in any frame.
  void hold_parts_apart() {
    const std::vector<float> clear = part_clearance_bounds(body_, base_, dir_, float(opt_.max_out));
    for (int v = 0; v < body_.num_body_verts(); ++v) {
      part_held_ += clear[size_t(v)] < 0.5f * upper_[size_t(v)];
      upper_[size_t(v)] = std::min(upper_[size_t(v)], clear[size_t(v)]);
    }
  }

  // The level's frames (downscaled) and texture (upsampled from the last level's).
  void enter_level(int lvl) {
    if (lvl == level_) return;
    const int L = schedule_.num_levels();
    const int full = std::min(opt_.resolution, std::max(frames_[0].camera.width, frames_[0].camera.height));
    const int side = level_side(opt_.texture_size, lvl, L);
    texture_ = texture_.empty() ? std::vector<float>(size_t(side) * side * 3, 0.5f) : resample_texture(texture_, texture_side_, side);
    texture_side_ = side;
    tex_adam_ = Adam();
    tex_adam_.add_group("texture", int64_t(texture_.size()), opt_.lr_texture, 3);
    level_frames_.clear();
    for (const TrainFrame& f : frames_) level_frames_.push_back(downscale_train_frame(f, level_side(full, lvl, L)));
    level_ = lvl;
  }

  // The textured body over a random background against the frame on the same background:
  // w_photo |I - gt|^2 per pixel; its gradient into d_texture_ and (when `move`) d_verts_.
  double photo_term(const TrainFrame& f, int s, bool move) {
    AvatarRenderRequest req;
    req.camera = &f.camera;
    req.body = &topology_;
    req.verts = verts_.data();
    const TextureView tv{texture_side_, texture_side_, 3, texture_.data()};
    req.texture = &tv;
    req.antialias = true;
    for (int c = 0; c < 3; ++c) req.background[c] = float(uniform01(seed_, kBackgroundStream, uint64_t(s) * 3 + uint64_t(c)));
    render_avatar(req, buf_);
    const int P = f.camera.width * f.camera.height;
    gt_.resize(3 * size_t(P));
    composite_ground_truth(f.rgb.data(), f.mask.data(), P, premultiplied_, req.background, gt_.data());
    d_image_.assign(3 * size_t(P), 0.0f);
    LossWeights w{};
    w.l2 = 3 * opt_.w_photo;  // the squared colour error summed over the channels, per pixel
    w.ssim = w.sobel = w.lpips = w.knn = w.dice = w.tv = 0;
    LossTerms terms;
    const double loss = image_loss(buf_.image.data(), gt_.data(), f.camera.height, f.camera.width, nullptr, w, loss_ctx_,
                                   d_image_.data(), 1.0f, terms);
    d_texture_.assign(texture_.size(), 0.0f);
    AvatarRenderGrads gr;
    gr.texture = d_texture_.data();
    gr.verts = move ? d_verts_.data() : nullptr;
    render_avatar_backward(req, buf_, d_image_.data(), nullptr, nullptr, gr);
    return loss;
  }

  // w_silhouette mean[outside m (1 - k) + (1 - m) k]; its gradient into d_verts_.
  double silhouette_term(const TrainFrame& f) {
    const int P = f.camera.width * f.camera.height;
    const std::vector<float>& cov = silhouette_.render(f.camera, verts_.data());
    d_sil_.resize(3 * size_t(P));
    const double loss = silhouette_mismatch(cov.data(), f.mask.data(), P, opt_.w_silhouette * opt_.outside, opt_.w_silhouette,
                                            d_sil_.data());
    silhouette_.backward(d_sil_.data(), d_verts_.data());
    return loss;
  }

  const BodyModel& body_;
  const std::vector<TrainFrame>& frames_;
  bool premultiplied_;
  const Stage0Config::Surface& opt_;
  uint64_t seed_;
  std::vector<int32_t> neighbors_;
  BodyTopology topology_;
  BodySilhouette silhouette_;
  VertexAdjacency adj_, garment_adj_;  // the body's faces; the garment's (no neighbours elsewhere)
  std::vector<float> upper_, lower_, h_, d_h_, normals_;
  std::vector<std::vector<float>> base_, dir_;
  LevelSchedule schedule_;
  int warmup_steps_ = 0, level_ = -1, texture_side_ = 0, part_held_ = 0;
  std::vector<TrainFrame> level_frames_;
  std::vector<float> texture_, d_texture_, verts_, d_verts_, gt_, d_image_, d_sil_;
  Adam tex_adam_, h_adam_;
  AvatarRenderBuffers buf_;
  ImageLossContext loss_ctx_;
};

}  // namespace

SurfaceFitReport fit_rest_surface(const BodyModel& body, const std::vector<TrainFrame>& frames, bool premultiplied,
                                  const Stage0Config::Surface& opt, uint64_t seed,
                                  const std::function<void(int, int, double)>& progress) {
  const int steps = opt.steps;
  if (steps <= 0 || frames.empty()) return {};
  check_frames(frames);
  SurfaceFit fit(body, frames, premultiplied, opt, seed);
  // The loss before and after: the first 5% of the steps that move the surface (the
  // texture has been learned by then) and the last 5%.
  const int first = std::min(steps - 1, int(std::lround(opt.warmup * steps)));
  const FitLossSpan span = run_fit_steps(steps, first, [&](int s) { return fit.step(s); }, progress);
  SurfaceFitReport rep = fit.report();
  rep.loss_start = span.start;
  rep.loss_end = span.end;
  return rep;
}

}  // namespace haha
