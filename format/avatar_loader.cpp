#include "format/avatar_loader.h"

#include <algorithm>
#include <array>

#include "body/face_frames.h"
#include "body/lbs.h"
#include "core/error.h"
#include "format/avatar_unpack.h"
#include "format/avatar_validate.h"

namespace haha {

namespace {

// Whether two face lists hold the same oriented triangles, in any order and with any
// rotation of each triangle's corners.
bool same_oriented_faces(const std::vector<int32_t>& a, const std::vector<int32_t>& b) {
  if (a.size() != b.size() || a.size() % 3) return false;
  auto canonical = [](const std::vector<int32_t>& f) {
    std::vector<std::array<int32_t, 3>> out(f.size() / 3);
    for (size_t i = 0; i < out.size(); ++i) {
      const int32_t* c = &f[i * 3];
      const int s = (c[0] <= c[1] && c[0] <= c[2]) ? 0 : (c[1] <= c[2] ? 1 : 2);
      out[i] = {c[s], c[(s + 1) % 3], c[(s + 2) % 3]};
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  return canonical(a) == canonical(b);
}

}  // namespace

struct AvatarLoader::State {
  Avatar avatar;
  std::unique_ptr<Lbs<float>> lbs;  // points into avatar.body: State never moves (unique_ptr)
  bool shaped = false;              // body has shape directions: apply the avatar's betas
  bool wants_correctives = false;   // the avatar was trained with pose correctives
  std::vector<AvatarAnimation> animations;
};

AvatarLoader::AvatarLoader(Avatar avatar) : s_(std::make_unique<State>()) {
  validate_avatar(avatar, avatar.body.source.empty() ? "avatar" : avatar.body.source);
  s_->avatar = std::move(avatar);
  const BodyModel& b = s_->avatar.body;
  s_->shaped = has_shape_blend(b);
  s_->wants_correctives = !b.posedirs.empty();
  s_->lbs = std::make_unique<Lbs<float>>(b);
}

AvatarLoader AvatarLoader::load(const std::string& path, const BodyModel* model, int max_gaussians) {
  UnpackOptions options;
  options.max_gaussians = max_gaussians;
  UnpackedAvatar u = read_avatar_file(path, options);
  AvatarLoader rt(std::move(u.avatar));
  rt.s_->wants_correctives = u.info.trained_with_pose_correctives || !u.info.pose_correctives.empty();
  if (model && !rt.has_pose_correctives()) rt.set_pose_correctives(*model);
  rt.set_animations(std::move(u.animations));
  return rt;
}

AvatarLoader::AvatarLoader(AvatarLoader&&) noexcept = default;
AvatarLoader& AvatarLoader::operator=(AvatarLoader&&) noexcept = default;
AvatarLoader::~AvatarLoader() = default;

const Avatar& AvatarLoader::avatar() const { return s_->avatar; }
int AvatarLoader::num_verts() const { return s_->avatar.body.num_verts; }
int AvatarLoader::num_gaussians() const { return s_->avatar.gaussians.size(); }
bool AvatarLoader::has_pose_correctives() const { return !s_->avatar.body.posedirs.empty(); }
bool AvatarLoader::missing_pose_correctives() const { return s_->wants_correctives && !has_pose_correctives(); }

const std::vector<AvatarAnimation>& AvatarLoader::animations() const { return s_->animations; }
void AvatarLoader::set_animations(std::vector<AvatarAnimation> animations) { s_->animations = std::move(animations); }

void AvatarLoader::set_pose_correctives(const BodyModel& model) {
  BodyModel& b = s_->avatar.body;
  const std::string where = model.source.empty() ? "body model" : model.source;
  // A garment (body/garment.h) has no correctives and is not the model's: the model must
  // be the avatar's body part, and the garment's rows stay zero.
  const int V = b.num_body_verts();
  const std::vector<int32_t> body_faces(b.faces.begin(), b.faces.begin() + long(b.num_body_faces()) * 3);
  // A file's faces may be in the encoder's order, each face's corners rotated: compare
  // the faces as sets of oriented triangles.
  const bool same_faces = model.faces == body_faces || same_oriented_faces(model.faces, body_faces);
  if (model.num_verts != V || !same_faces) {
    fail(where, "pose correctives: the body model's mesh (" + std::to_string(model.num_verts) +
                    " vertices) is not the avatar's body (" + std::to_string(V) + ")");
  }
  if (model.posedirs.size() != size_t(model.num_verts) * 3 * kNumPoseFeatures) fail(where, "posedirs: missing");
  b.posedirs = model.posedirs;
  b.posedirs.resize(size_t(b.num_verts) * 3 * kNumPoseFeatures, 0.0f);
  s_->lbs = std::make_unique<Lbs<float>>(b);
}

void AvatarLoader::repose(const SmplxParams& params, PosedAvatar& out) const {
  const Avatar& a = s_->avatar;
  SmplxParams p;
  p.pose = params.pose;
  p.transl = params.transl;
  if (s_->shaped) {
    p.betas = a.betas;
    p.expression = a.expression;
  }
  const int V = a.body.num_verts, N = a.gaussians.size();
  out.num_verts = V;
  out.num_gaussians = N;
  out.verts.resize(size_t(V) * 3);
  out.joints.resize(size_t(kNumJoints) * 3);
  s_->lbs->forward(p, out.verts.data(), out.joints.data(), nullptr);
  out.means.resize(size_t(N) * 3);
  out.quats.resize(size_t(N) * 4);
  out.scales.resize(size_t(N) * 3);
  pose_gaussians(out.verts.data(), a.body, a.face_scale_divisor, a.gaussians, out.means.data(), out.quats.data(),
                 out.scales.data());
  out.colors = a.gaussians.color.data();
  out.opacities = a.gaussians.opacity.data();
}

void AvatarLoader::render(const Camera& cam, const PosedAvatar& posed, std::vector<float>& rgb,
                           const AvatarRenderOptions& options) const {
  AvatarRenderScratch scratch;
  render(cam, posed, rgb, options, scratch);
}

void AvatarLoader::render(const Camera& cam, const PosedAvatar& posed, std::vector<float>& rgb,
                           const AvatarRenderOptions& options, AvatarRenderScratch& s) const {
  const Avatar& a = s_->avatar;
  if (posed.num_verts != a.body.num_verts || posed.verts.size() != size_t(posed.num_verts) * 3 ||
      posed.num_gaussians != a.gaussians.size()) {
    fail("render", "posed frame does not belong to this avatar (call repose first)");
  }
  if (cam.width <= 0 || cam.height <= 0) fail("render", "camera has no pixels");
  const AvatarViews views(a);
  AvatarRenderRequest req = avatar_request(a, views, cam, posed.verts.data(), options.draw_mesh,
                                           options.draw_gaussians && a.gaussians.size() > 0);
  for (int c = 0; c < 3; ++c) req.background[c] = options.background[c];
  render_avatar(req, s.buffers);
  rgb.assign(s.buffers.image.begin(), s.buffers.image.end());
}

}  // namespace haha
