// A pose pre-fit to the person masks (before stage 1): per frame, global orient, body pose
// and transl move so that the body's antialiased silhouette (render/mesh_antialias.h) lies
// inside the mask and covers it. Clothes and hair make the mask larger than the body, so the
// two sides weigh differently: body outside the mask costs `w_outside`, mask left uncovered
// costs `w_inside` (small); both are means over the pixels. A prior `w_prior` on the squared
// change from the given fit holds the joints a silhouette does not constrain; with
// `s0.window` > 0 that anchor is the fit averaged over neighbouring frames (a temporal prior
// for monocular video: independent fit errors average out). Opt-in (`s0.steps`).
#pragma once

#include <functional>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "render/avatar_render.h"
#include "train/trainer.h"

namespace haha {

// The body's antialiased silhouette (render/mesh_antialias.h) for silhouette terms: the
// mesh rendered white, so each image channel holds the coverage m in [0, 1], with the
// vertex gradient at its edges.
class BodySilhouette {
 public:
  explicit BodySilhouette(const BodyModel& body);  // keeps a pointer to body
  BodySilhouette(const BodySilhouette&) = delete;
  BodySilhouette& operator=(const BodySilhouette&) = delete;
  // The coverage image (P, 3) of the body posed as verts (V, 3) seen by camera.
  const std::vector<float>& render(const Camera& camera, const float* verts);
  // Adds dL/dverts (V, 3) for dL/dimage (P, 3) of the last render (same camera and verts).
  void backward(const float* d_image, float* d_verts);

 private:
  std::vector<int32_t> neighbors_;
  BodyTopology topology_;
  float white_[3] = {1, 1, 1};
  TextureView texture_;
  Camera camera_;
  AvatarRenderRequest req_;
  AvatarRenderBuffers buf_;
};

// L = mean over pixels of [w_outside m (1 - k) + w_inside (1 - m) k] for the coverage m
// (channel 0 of image, (P, 3)) against the mask k (P); dL/dimage into d_image (P, 3),
// overwritten (channels 1, 2 zero).
double silhouette_mismatch(const float* image, const float* mask, int num_pixels, double w_outside, double w_inside,
                           float* d_image);

struct SilhouetteFitReport {
  std::vector<double> loss_start, loss_end;  // per frame
};

// The anchors of the prior: each frame's body group (kPoseBodyGroup values: orient, body
// pose, transl) averaged over frames [i - half_window, i + half_window] (clipped at the
// ends). Rotations are averaged in the tangent space at the frame's own rotation (no wrap at
// pi), translations linearly.
std::vector<std::vector<float>> temporal_pose_anchors(const std::vector<TrainFrame>& frames, int half_window);

// Updates every frame's params in place (betas and expression untouched). `progress`
// (optional) is called after each frame with the frames done and their count.
SilhouetteFitReport fit_poses_to_masks(const BodyModel& body, std::vector<TrainFrame>& frames,
                                       const Stage0Config& opt,
                                       const std::function<void(int done, int total)>& progress = {});

}  // namespace haha
