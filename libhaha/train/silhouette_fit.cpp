#include "train/silhouette_fit.h"

#include <cmath>

#include "body/lbs.h"
#include "core/parallel.h"
#include "render/avatar_render.h"
#include "render/mesh_antialias.h"
#include "train/adam.h"
#include "train/pose_groups.h"

namespace haha {

SilhouetteFitReport fit_poses_to_masks(const BodyModel& body, std::vector<TrainFrame>& frames,
                                       const Stage0Config& opt) {
  SilhouetteFitReport rep;
  if (opt.steps <= 0) return rep;
  const std::vector<int32_t> neighbors = mesh_face_neighbors(body.faces.data(), body.num_faces, body.num_verts);
  BodyTopology topology = topology_of(body);
  topology.face_neighbors = neighbors.data();
  const float white[3] = {1, 1, 1};
  const TextureView texture{1, 1, 3, white};  // coverage only: the image is m' in every channel
  Lbs<float> lbs(body);
  LbsCache<float> cache;
  AvatarRenderBuffers buf;
  std::vector<float> verts(3 * size_t(body.num_verts)), d_verts, d_image;
  for (TrainFrame& f : frames) {
    const int P = f.camera.width * f.camera.height;
    SmplxParams& p = f.params;
    Adam adam;
    const int gb = adam.add_group("body", kPoseBodyGroup, opt.lr);
    std::vector<float> pb(kPoseBodyGroup), pf(kPoseFineGroup), db(kPoseBodyGroup), dfn(kPoseFineGroup);
    std::vector<float> p0(kPoseBodyGroup);
    pose_to_groups(p, p0.data(), pf.data());
    AvatarRenderRequest req;
    req.camera = &f.camera;
    req.body = &topology;
    req.verts = verts.data();
    req.texture = &texture;
    req.antialias = true;
    for (int s = 0; s <= opt.steps; ++s) {
      lbs.forward(p, verts.data(), nullptr, &cache);
      render_avatar(req, buf);
      // L = mean_p [w_out m (1 - mask) + w_in (1 - m) mask]; the image holds m in each channel.
      double loss = 0;
      d_image.assign(3 * size_t(P), 0.0f);
      for (int q = 0; q < P; ++q) {
        const double m = buf.image[3 * size_t(q)], k = f.mask[size_t(q)];
        loss += opt.w_outside * m * (1 - k) + opt.w_inside * (1 - m) * k;
        d_image[3 * size_t(q)] = float((opt.w_outside * (1 - k) - opt.w_inside * k) / P);
      }
      loss /= P;
      pose_to_groups(p, pb.data(), pf.data());
      for (int k = 0; k < kPoseBodyGroup; ++k) loss += opt.w_prior * double(pb[k] - p0[k]) * (pb[k] - p0[k]);
      if (s == 0) rep.loss_start.push_back(loss);
      if (s == opt.steps) {
        rep.loss_end.push_back(loss);
        break;
      }
      d_verts.assign(verts.size(), 0.0f);
      AvatarRenderGrads gr;
      gr.verts = d_verts.data();
      render_avatar_backward(req, buf, d_image.data(), nullptr, nullptr, gr);
      SmplxGrad<float> sg = lbs.make_grad(p);
      lbs.backward(p, cache, d_verts.data(), nullptr, sg);
      pose_to_groups(sg, db.data(), dfn.data());
      for (int k = 0; k < kPoseBodyGroup; ++k) db[k] += float(2 * opt.w_prior * (pb[k] - p0[k]));
      bool finite = true;
      for (float v : db) finite = finite && std::isfinite(v);
      if (!finite) break;
      adam.step(gb, pb.data(), db.data());
      groups_to_pose(pb.data(), pf.data(), p);
    }
  }
  return rep;
}

}  // namespace haha
