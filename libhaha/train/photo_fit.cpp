#include "train/photo_fit.h"

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
#include "train/pose_groups.h"
#include "train/silhouette_fit.h"

namespace haha {

namespace {

constexpr uint64_t kOrderStream = 0x50f0, kBackgroundStream = 0x50f1;

void check_frames(const std::vector<TrainFrame>& frames) {
  const Camera& c0 = frames[0].camera;
  for (const TrainFrame& f : frames) {
    const size_t P = size_t(f.camera.width) * f.camera.height;
    if (f.camera.width != c0.width || f.camera.height != c0.height)
      fail(f.name, "photometric pose fit: frames of different sizes");
    if (f.mask.size() != P || f.rgb.size() != 3 * P) fail(f.name, "photometric pose fit: needs the image and its mask");
  }
}

// The state of the fit: the shared texture with its optimiser (made anew at each level) and
// the frames' pose groups with theirs.
class PhotoFit {
 public:
  PhotoFit(const BodyModel& body, std::vector<TrainFrame>& frames, bool premultiplied, const Stage0Config& s0,
           uint64_t seed)
      : body_(body), frames_(frames), premultiplied_(premultiplied), opt_(s0.photo), seed_(seed), lbs_(body),
        neighbors_(mesh_face_neighbors(body.faces.data(), body.num_faces, body.num_verts)), topology_(topology_of(body)) {
    topology_.face_neighbors = neighbors_.data();
    schedule_ = make_level_schedule(opt_.levels, opt_.steps, "s0.photo.levels");
    warmup_steps_ = int(std::lround(opt_.warmup * opt_.steps));
    const int n = int(frames.size());
    anchors_ = s0.window > 0 ? temporal_pose_anchors(frames, s0.window) : std::vector<std::vector<float>>();
    std::vector<float> fine(kPoseFineGroup);
    betas_ = video_betas(frames, body.num_shape);  // the trainer's shape, in every frame
    for (TrainFrame& f : frames) f.params.betas = betas_;
    for (int i = 0; i < n; ++i) {
      pose_adam_.add_group("frame" + std::to_string(i), kPoseBodyGroup, opt_.lr);
      if (s0.window <= 0) {
        anchors_.emplace_back(kPoseBodyGroup);
        pose_to_groups(frames[size_t(i)].params, anchors_.back().data(), fine.data());
      }
    }
    betas_group_ = pose_adam_.add_group("betas", int64_t(betas_.size()), opt_.lr_betas);
  }

  // One step: returns the image loss (NaN when the step was skipped for a non-finite value).
  double step(int s) {
    enter_level(schedule_.level_of(s));
    const int fi = epoch_draw(seed_, kOrderStream, int(frames_.size()), s);
    const TrainFrame& f = level_frame(fi);
    SmplxParams& p = frames_[size_t(fi)].params;
    const bool move_pose = s >= warmup_steps_;
    verts_.resize(3 * size_t(body_.num_verts));
    lbs_.forward(p, verts_.data(), nullptr, move_pose ? &cache_ : nullptr);
    AvatarRenderRequest req;
    req.camera = &f.camera;
    req.body = &topology_;
    req.verts = verts_.data();
    const TextureView tv{texture_side_, texture_side_, 3, texture_.data()};
    req.texture = &tv;
    req.antialias = true;
    for (int c = 0; c < 3; ++c) req.background[c] = float(uniform01(seed_, kBackgroundStream, uint64_t(s) * 3 + uint64_t(c)));
    render_avatar(req, buf_);
    const double loss = image_term(f, req.background);
    d_texture_.assign(texture_.size(), 0.0f);
    d_verts_.assign(verts_.size(), 0.0f);
    AvatarRenderGrads gr;
    gr.texture = d_texture_.data();
    gr.verts = move_pose ? d_verts_.data() : nullptr;
    render_avatar_backward(req, buf_, d_image_.data(), nullptr, nullptr, gr);
    if (!std::isfinite(loss) || !all_finite(d_texture_) || !all_finite(d_verts_)) return NAN;
    tex_adam_.set_lr(0, LogLinearLr{opt_.lr_texture, opt_.lr_texture_final, opt_.steps}(s));
    tex_adam_.step(0, texture_.data(), d_texture_.data());
    for (float& t : texture_) t = std::clamp(t, 0.0f, 1.0f);
    if (move_pose) update_pose(fi, p);
    return loss;
  }

  PhotoFitReport report() const {
    PhotoFitReport r;
    r.texture = texture_;
    r.texture_side = texture_side_;
    return r;
  }

 private:
  // The level's frames (downscaled on first use) and texture (upsampled from the last).
  void enter_level(int lvl) {
    if (lvl == level_) return;
    const int L = schedule_.num_levels();
    const int full = std::max(frames_[0].camera.width, frames_[0].camera.height);
    const int side = level_side(opt_.texture_size, lvl, L);
    texture_ = texture_.empty() ? std::vector<float>(size_t(side) * side * 3, 0.5f)
                                : resample_texture(texture_, texture_side_, side);
    texture_side_ = side;
    tex_adam_ = Adam();
    tex_adam_.add_group("texture", int64_t(texture_.size()), opt_.lr_texture, 3);
    level_frames_.clear();
    if (lvl < L - 1)
      for (const TrainFrame& f : frames_) level_frames_.push_back(downscale_train_frame(f, level_side(full, lvl, L)));
    level_ = lvl;
  }
  const TrainFrame& level_frame(int fi) const {
    return level_frames_.empty() ? frames_[size_t(fi)] : level_frames_[size_t(fi)];
  }

  // The image loss (L2, and 1 - SSIM and the edge loss when weighted) and its gradient
  // (d_image_). Pixels the mesh does not cover have no gradient (only the antialiased edge
  // moves the outline).
  double image_term(const TrainFrame& f, const float bg[3]) {
    const int P = f.camera.width * f.camera.height;
    gt_.resize(3 * size_t(P));
    composite_ground_truth(f.rgb.data(), f.mask.data(), P, premultiplied_, bg, gt_.data());
    d_image_.assign(3 * size_t(P), 0.0f);
    LossWeights w{};
    w.l2 = 3;  // the squared colour error summed over the channels, per pixel
    w.ssim = opt_.w_ssim;
    w.sobel = opt_.w_sobel;
    w.lpips = w.knn = w.dice = w.tv = 0;
    LossTerms terms;
    return image_loss(buf_.image.data(), gt_.data(), f.camera.height, f.camera.width, nullptr, w, loss_ctx_,
                      d_image_.data(), 1.0f, terms);
  }

  // Adam on the frame's body group: the image gradient through LBS plus the prior's.
  void update_pose(int fi, SmplxParams& p) {
    SmplxGrad<float> sg = lbs_.make_grad(p);
    lbs_.backward(p, cache_, d_verts_.data(), nullptr, sg);
    std::vector<float> pb(kPoseBodyGroup), pf(kPoseFineGroup), db(kPoseBodyGroup), dfn(kPoseFineGroup);
    pose_to_groups(p, pb.data(), pf.data());
    pose_to_groups(sg, db.data(), dfn.data());
    const std::vector<float>& a = anchors_[size_t(fi)];
    for (int k = 0; k < kPoseBodyGroup; ++k) db[size_t(k)] += float(2 * opt_.w_prior * (pb[size_t(k)] - a[size_t(k)]));
    if (!all_finite(db) || !all_finite(sg.betas)) return;
    pose_adam_.step(fi, pb.data(), db.data());
    groups_to_pose(pb.data(), pf.data(), p);
    if (opt_.lr_betas > 0) {
      pose_adam_.step(betas_group_, betas_.data(), sg.betas.data());
      for (TrainFrame& f : frames_) f.params.betas = betas_;
    }
  }

  static bool all_finite(const std::vector<float>& v) {
    return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
  }

  const BodyModel& body_;
  std::vector<TrainFrame>& frames_;
  bool premultiplied_;
  const Stage0Config::Photo& opt_;
  uint64_t seed_;
  Lbs<float> lbs_;
  LbsCache<float> cache_;
  std::vector<int32_t> neighbors_;
  BodyTopology topology_;
  LevelSchedule schedule_;
  int warmup_steps_ = 0, level_ = -1, texture_side_ = 0, betas_group_ = -1;
  std::vector<std::vector<float>> anchors_;
  std::vector<TrainFrame> level_frames_;
  std::vector<float> betas_, texture_, d_texture_, verts_, d_verts_, gt_, d_image_;
  Adam tex_adam_, pose_adam_;
  AvatarRenderBuffers buf_;
  ImageLossContext loss_ctx_;
};

}  // namespace

PhotoFitReport fit_poses_to_images(const BodyModel& body, std::vector<TrainFrame>& frames, bool premultiplied,
                                   const Stage0Config& s0, uint64_t seed,
                                   const std::function<void(int, int, double)>& progress) {
  const int steps = s0.photo.steps;
  if (steps <= 0 || frames.empty()) return {};
  check_frames(frames);
  PhotoFit fit(body, frames, premultiplied, s0, seed);
  const FitLossSpan span = run_fit_steps(steps, 0, [&](int s) { return fit.step(s); }, progress);
  PhotoFitReport rep = fit.report();
  rep.loss_start = span.start;
  rep.loss_end = span.end;
  return rep;
}

}  // namespace haha
