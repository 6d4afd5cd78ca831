// The objective of the video fit (fit/fit_video.h), SMPLify-X style, with its gradient,
// in float (the fit) and double (finite-difference tests). Parameters, flat: per frame
// [global orient 3 | body pose 63 | transl 3] (kFitVideoFrameParams), then the betas shared
// by all frames. With N frames and H the frame height:
//
//   E = 1/N sum_f [ w_kp sum_k c_fk rho(|pi(X_fk) - x_fk|^2 / H^2)         robust reprojection
//                 + w_pose sum_j alpha_j |theta_fj|^2                       prior towards rest
//                 + w_limit sum_{knees, elbows} max(0, -s theta_bend)^2     bend one way only
//                 + w_behind sum_k max(0, z_min - Z_fk)^2 ]                 keypoints behind the camera
//                 + w_world sum_b v_fb rho_w(|d_fb - e_fb|^2) ]                   3D bone directions
//     + 1/N sum_{f linked to f-1} [ w_sp |theta_f - theta_f-1|^2 + w_st |t_f - t_f-1|^2 ] (dt_ref / dt_f)^2
//     + w_betas |betas|^2  (+ an optional per-frame term on the posed vertices, e.g. the silhouette)
//
// rho(s) = sigma^2 s / (sigma^2 + s) (Geman-McClure), c_fk = point weight x visibility.
// The bone term (BlazePose's world points, when a frame has them): d_fb is the unit direction
// of bone b (fit/fit_video_points.h, fit_video_bones) of the posed body in camera axes, e_fb
// the unit direction between the bone's two world points (BlazePose's world frame is
// image-aligned: camera axes up to a translation), v_fb the smaller visibility of its two
// ends and rho_w Geman-McClure with sigma world_sigma: a weak depth cue that tells an elbow
// bent towards the camera from a straight arm, robust to BlazePose's flips.
// X_fk: the SMPL-X joint or vertex of point k (fit/fit_video_points.h) posed by LBS
// (body/lbs.h, whose backward gives the parameter gradient). pi projects through the camera
// with the depth clamped to z_min, so a point behind the camera gives no division by zero;
// the behind term pulls it back in front. theta = axis-angle; alpha_j is larger on the spine,
// collars, neck, head, feet and on the knees' non-hinge axes. Knees flex about +x (SMPL-X
// rest pose); the left elbow about -y, the right about +y.
#pragma once

#include <functional>
#include <vector>

#include "fit/fit_video_points.h"
#include "body/body_model.h"
#include "body/lbs.h"
#include "core/camera.h"

namespace haha {

constexpr int kFitVideoPoseValues = 66;  // global orient + 21 body joints
constexpr int kFitVideoFrameParams = kFitVideoPoseValues + 3;
constexpr double kFitVideoMinDepth = 0.1;  // metres: z_min of the projection
// The smoothness weights are per frame pair dt_ref = 1/30 s apart; a pair dt apart is
// weighted (dt_ref / dt)^2 (a penalty on the squared velocity), so the balance between the
// data and the smoothness does not change with the frame rate or the --frames step.
constexpr double kFitVideoSmoothInterval = 1.0 / 30;

struct FitVideoWeights {
  double keypoints = 1.0;      // w_kp
  double gm_sigma = 0.1;       // Geman-McClure sigma, in frame heights
  double pose_prior = 1e-4;    // w_pose (rad^-2)
  double angle_limit = 1e-1;   // w_limit (rad^-2)
  double smooth_pose = 1e-2;   // w_sp (rad^-2)
  double smooth_transl = 1e-2; // w_st (m^-2)
  // > 0: the body joints' smoothness is robust (Geman-McClure on the change per dt_ref,
  // sigma in radians), so a jump between stills or a fast move is not pulled towards its
  // neighbours; 0: quadratic. The global orient stays quadratic (a turn is fast, and robust
  // there lost the turn's consistency: docs/fit-video.md).
  double smooth_sigma = 0;
  double betas = 1e-4;         // w_betas
  double behind = 1.0;         // w_behind (m^-2)
  double world = 2e-3;         // w_world (0: off); chosen by measurement, docs/fit-video.md
  double world_sigma = 0.5;    // Geman-McClure sigma of the bone term (unit-vector distance)
};

// One frame's 2D targets, indexed like the correspondence.
struct FitVideoTargets {
  std::vector<double> x, y;  // pixels
  std::vector<double> vis;   // visibility in [0, 1] (0: not used)
  std::vector<double> world; // empty, or 3 per point: its BlazePose world point (metres, camera axes)
  bool linked = false;       // smoothness with the previous frame of the list
  double dt = kFitVideoSmoothInterval;  // seconds since that frame (> 0)
};

// The parts of E (for progress and tests).
struct FitVideoTerms {
  double keypoints = 0, prior = 0, limits = 0, behind = 0, smooth = 0, betas = 0, extra = 0, world = 0;
  double total() const { return keypoints + prior + limits + behind + smooth + betas + extra + world; }
};

// The prior factor alpha of pose value k in [0, 66) (the global orient's are 0).
double fit_video_prior_factor(int k);

template <class T>
class FitVideoObjective {
 public:
  // An extra per-frame term: posed vertices (V, 3) in, its value out, dE/dverts added to
  // d_verts (V, 3). It is added to E as is (not divided by N).
  using Extra = std::function<T(int frame, const T* verts, T* d_verts)>;

  FitVideoObjective(const BodyModel& body, std::vector<FitVideoPoint> points, const CameraT<T>& camera, int num_betas,
                    const FitVideoWeights& w);

  int num_betas() const { return nb_; }
  int num_params(int frames) const { return frames * kFitVideoFrameParams + nb_; }
  const std::vector<FitVideoPoint>& points() const { return points_; }
  // Overrides the points' weights (the first stage uses the torso and face points only).
  void set_point_weights(const std::vector<double>& w) { point_w_ = w; }

  // E for targets.size() frames; grad (num_params, may be null) is overwritten.
  T evaluate(const std::vector<FitVideoTargets>& targets, const T* params, T* grad, const Extra& extra = {},
             FitVideoTerms* terms = nullptr) const;

  // The projected points (pixels; the depth clamped as in E) of one frame's parameters.
  void project(const T* frame_params, const T* betas, std::vector<T>& u, std::vector<T>& v) const;
  // The points in camera space (metres, camera axes) of one frame's parameters.
  std::vector<Vec3<T>> camera_points(const T* frame_params, const T* betas) const;

  // Frame parameters as SmplxParams (betas from the shared block).
  static SmplxParams to_params(const T* frame_params, const T* betas, int num_betas);

 private:
  void pose_frame(const T* frame_params, const T* betas, std::vector<T>& pose, std::vector<T>& verts,
                  std::vector<T>& joints, LbsCache<T>* cache) const;

  Lbs<T> lbs_;
  std::vector<FitVideoPoint> points_;
  std::vector<FitVideoBone> bones_;
  std::vector<double> point_w_;
  CameraT<T> cam_;
  int nb_;
  FitVideoWeights w_;
};

extern template class FitVideoObjective<float>;
extern template class FitVideoObjective<double>;

}  // namespace haha
