// The synthetic subject: the project's embedded sample (`haha synth`). A clothed person
// built on any SMPL-X-layout body model (normally the procedural body), rendered as a
// monocular video in memory (no file I/O; data/synth_dataset.h writes it in the native
// dataset format).
//
// What it is made of, and why (HAHA = textured mesh + Gaussians where the mesh fails):
//  - a UV texture on the body's own atlas (vt, ft): skin, a checked shirt with a chest
//    emblem and lettering on the back, striped trousers, shoes, a face (eyes, brows, lips),
//    a watch on the left wrist, finger nails, hair colour on the scalp. It is painted from
//    the 3D rest surface (position, normal, skinning-weight groups), so it works for any
//    body with a UV map. This part is exactly representable by a texture on that atlas.
//  - geometry that LEAVES the body surface and needs Gaussians: a hair shell (the scalp
//    offset outward by up to ~3 cm, tapering to the hairline; body UVs and texture), a
//    ponytail (a tube skinned rigidly to the head) and a pleated, flared skirt (a frustum
//    from the waist to above the knees, skinned to the pelvis and both hips with smooth
//    weights that follow the thighs). Skirt and ponytail use a second texture (tartan,
//    hair streaks and a hair tie).
//  - motions: training = turning in place (one full turn of global_orient about the
//    vertical axis) with arm swings, elbow bends, head motion and finger curls; test =
//    novel poses (arms raised / forward, knees bent, spread / pointing / fist hands). Every
//    test pose differs from every training pose by at least kSynthMinPoseGap at some joint.
//  - ground truth rendered from this clothed geometry with the mesh rasterizer (supersampled
//    and box-filtered, black background, soft coverage masks), never from an avatar.
//  - a static OpenCV camera ~2.8 m in front of the subject (body Y up -> camera y down),
//    focal chosen so every frame's clothed subject fits with a margin.
// Subject 2 (`--subject 2`, synth_subject_coat.cpp), the harder benchmark subject: another
// body shape (betas: taller, heavier, wider hips and shoulders), its own palette, long
// loose hair (a sheet from above the ears falling down the back past the shoulder blades,
// clear of head, body and coat, skinned head -> neck -> spine3 -> spine2 so it shears when
// the head turns) over a hair shell, and a loose coat: a jacket shell over the torso and
// the upper arms standing 3 to 5.5 cm off the body (sleeves flaring toward the cuff), plus
// long tails from the waist to below the knees (a flared skirt with soft folds).
//
// View-dependent shading (SynthRenderer::set_view_shading, `--view-shading S`): a rim sheen
// and a specular highlight of a fixed world light on meshes with gloss > 0 (hair 0.7, cloth
// 1); a diffuse texture cannot hold it. Off (0) by default for subject 1, 0.5 for subject 2.
// Everything is deterministic for a seed.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/smplx_params.h"
#include "core/image.h"
#include "core/camera.h"
#include "render/mesh_raster.h"

namespace haha {

// ---------------------------------------------------------------------------------------
// The clothed subject (geometry on the shaped rest body + textures).

// A mesh that is not the body, skinned with the body's joint transforms.
struct SynthMesh {
  std::string name;             // "hair", "ponytail", "skirt", "long_hair", "coat", "coat_tails"
  unsigned part = 0;            // its SynthPart bit (the renderer's selection)
  float gloss = 0;              // response to view-dependent shading (0: none)
  bool garment = false;         // a garment around both legs (skirt, coat tails): the part mask's pixels
  std::vector<float> rest;      // (V, 3) rest-pose positions (on the shaped rest body)
  std::vector<int32_t> faces;   // (F, 3)
  std::vector<float> vt;        // (T, 2) UVs, v up (body convention)
  std::vector<int32_t> ft;      // (F, 3) UV index per face corner
  int texture = 0;              // 0: SynthSubject::body_texture, 1: garment_texture
  // Skinning weights, CSR: vertex v uses entries [w_start[v], w_start[v + 1]).
  std::vector<int32_t> w_start, w_joint;
  std::vector<float> w_value;
  int num_verts() const { return int(rest.size() / 3); }
  int num_faces() const { return int(faces.size() / 3); }
};

struct SynthSubjectOptions {
  uint64_t seed = 0;       // colours and pattern details
  int texture_size = 512;  // body atlas side; the garment atlas is texture_size x texture_size/2
  int subject = 1;         // 1: skirt and ponytail; 2: long hair and coat (see above)
  bool hair = true, ponytail = true, skirt = true;  // subject 1's pieces
};

struct SynthSubject {
  std::vector<float> betas;          // the subject's shape (zeros: the model's template)
  std::vector<float> rest_verts;     // (V, 3) shaped rest body
  std::vector<float> rest_joints;    // (55, 3)
  std::vector<SynthMesh> meshes;     // subject 1: hair, ponytail, skirt (those enabled);
                                     // subject 2: hair, coat, coat_tails, long_hair
  Image body_texture;                // (S, S, 3) on the body's UV atlas
  Image garment_texture;             // (S/2, S, 3): skirt or coat tails (upper part),
                                     // ponytail or long hair (lower part)
};

// Builds the subject on `body` (which needs vt/ft). Throws haha::Error naming the model's
// source if it has no UV map, the texture size is outside [16, 8192] or the subject is
// not 1 or 2.
SynthSubject make_synth_subject(const BodyModel& body, const SynthSubjectOptions& opt = {});

// ---------------------------------------------------------------------------------------
// Motions.

// Minimum, over all (test, train) pairs, of the largest per-joint rotation difference
// guaranteed by the motion design (radians, 20 degrees).
constexpr double kSynthMinPoseGap = 0.349;

struct SynthMotion {
  std::vector<SmplxParams> train, test;  // true parameters; feet on the rest floor
};

// Frames are deterministic for (body, counts, seed, still_arms). Frame i of train turns by
// 360 * i / n degrees about the vertical axis (frame 0 faces the camera). The arms swing
// forward and back, rise and fall and bend at the elbows as it turns; still_arms holds
// them in one A-pose over the turn instead (the capture protocol of PeopleSnapshot-style
// datasets), the rest of the motion unchanged.
SynthMotion make_synth_motion(const BodyModel& body, const SynthSubject& subject, int train_frames, int test_frames,
                              uint64_t seed, bool still_arms = false);

// Largest geodesic angle (radians) between the two poses' local rotations over the
// articulated joints 1..54 (global orientation excluded: it is the viewpoint).
double pose_distance(const SmplxParams& a, const SmplxParams& b);

// Fit error imitation: standard deviations of the Gaussian noise on every pose value but the
// eye joints' (radians) and on transl (metres).
struct FitNoise {
  double pose = 0, transl = 0;
};
// Deterministic for seed; the same draws for any sigmas (only their scale changes).
std::vector<SmplxParams> perturb_fits(const std::vector<SmplxParams>& truth, FitNoise sigma, uint64_t seed);

// ---------------------------------------------------------------------------------------
// Rendering.

enum SynthPart : unsigned {
  kSynthBody = 1u,
  kSynthHair = 2u,
  kSynthPonytail = 4u,
  kSynthSkirt = 8u,
  kSynthLongHair = 16u,
  kSynthCoat = 32u,  // coat and coat_tails
  kSynthAll = 63u,
};

// Renders the subject; holds the LBS and scratch buffers (not thread-safe: one per thread;
// copies are cheap before first use and share the LBS data). `body` and `subject` must
// outlive it.
class SynthRenderer {
 public:
  SynthRenderer(const BodyModel& body, const SynthSubject& subject);

  // Posed vertices of the selected parts, concatenated (body first, then subject.meshes
  // in order), world space including transl.
  void pose(const SmplxParams& p, unsigned parts, std::vector<float>& verts);

  // Anti-aliased render: the image is rasterized at supersample x the camera's size and
  // box-filtered. rgb (H, W, 3) on black; mask (H, W, 1) = covered fraction of subsamples;
  // garment (optional, (H, W, 1)) = fraction of subsamples whose visible surface is a mesh
  // with SynthMesh::garment set (all zero when there is none).
  void render(const Camera& cam, const SmplxParams& p, int supersample, unsigned parts, Image& rgb, Image& mask,
              Image* garment = nullptr);

  // Strength of the view-dependent shading (synth_internal.h view_shade) on meshes with
  // gloss > 0; 0 (the default) renders the textures alone. Throws for a value outside [0, 2].
  void set_view_shading(double strength);
  double view_shading() const { return view_shading_; }

 private:
  const BodyModel& body_;
  const SynthSubject& subject_;
  Lbs<float> lbs_;
  LbsCache<float> cache_;
  std::vector<float> verts_;
  std::vector<int32_t> faces_;
  unsigned faces_parts_ = 0;
  double view_shading_ = 0;
  std::vector<float> normals_;
  struct Range {
    int first_face, num_faces, texture;
    float gloss;
    bool garment;
    const float* vt;
    const int32_t* ft;
  };
  std::vector<Range> ranges_;
  MeshRaster raster_;
};

// Static camera looking at the subject along -Z from `distance` metres (world +Z side),
// level, principal point at the image centre, focal length such that every vertex of every
// given frame projects inside the central `fill` fraction of the image.
// Frames are posed in parallel on copies of `renderer`.
Camera synth_camera(const SynthRenderer& renderer, const std::vector<const SmplxParams*>& frames, int size,
                    double distance = 2.8, double fill = 0.9);

// A camera that looks at one frame's posed subject (all parts) from `distance` metres off the
// centre of its bounding box, raised by `elevation` radians above the horizontal on the +Z
// side (> 0: above, looking down; < 0: below, looking up; 0: synth_camera's level view),
// image x along world +X, principal point at the centre, focal length such that every vertex
// projects inside the central `fill` fraction. Throws haha::Error when a vertex lies behind
// the camera.
Camera synth_view_camera(SynthRenderer& renderer, const SmplxParams& frame, int size, double distance,
                         double elevation, double fill = 0.9);

// Views a turn in place never shows (`haha synth --unseen`), one frame each, in this order:
// from below the chin looking up, from above the head looking down (both in a standing pose
// facing the camera, arms down), and the arms raised above the shoulders seen from the front.
enum SynthUnseenView : int { kUnseenBelow, kUnseenAbove, kUnseenArmsUp, kSynthUnseenViews };
const char* synth_unseen_view_name(int view);  // "below chin", "above head", "arms raised"
// Elevation (radians) of the below and above views' cameras.
constexpr double kUnseenBelowElevation = -0.8, kUnseenAboveElevation = 0.9;
// The true parameters of the kSynthUnseenViews frames, grounded as the turn's frames are.
std::vector<SmplxParams> make_synth_unseen_poses(const BodyModel& body, const SynthSubject& subject);

// ---------------------------------------------------------------------------------------
// The frames of `haha synth`, in memory (data/synth_dataset.h writes them as a dataset).

struct SynthOptions {
  int size = 128;           // image side in pixels
  int train_frames = 40;
  int test_frames = 10;
  uint64_t seed = 0;
  FitNoise fit_noise;       // sigmas of perturb_fits (0: fits are the true parameters)
  int supersample = 3;      // subsamples per pixel side
  int texture_size = 0;     // 0: automatic (512 up to 256 px, 1024 up to 512 px, else 2048)
  double camera_distance = 2.8;
  int sheet_train = 40, sheet_test = 10;  // frames shown on the contact sheet (evenly spaced)
  int subject = 1;            // SynthSubjectOptions::subject
  double view_shading = -1;   // strength; < 0: the subject's default (0 for 1, 0.5 for 2)
  bool still_arms = false;    // make_synth_motion's still_arms
  bool unseen = false;        // also the kSynthUnseenViews frames (split unseen, own cameras)
};

// The view-shading strength a subject gets when none is given.
double default_view_shading(int subject);

// Throws haha::Error "--size: ...", "--frames: ...", "--subject: ...", ... for out-of-range
// options.
void validate_synth_options(const SynthOptions& opt);

// What the frames are rendered from: frame i < options.train_frames is training frame i
// (the turn), then options.test_frames test frames (novel poses), then the unseen views
// (one per unseen_cameras entry, SynthUnseenView order).
struct SynthScene {
  SynthOptions options;
  SynthSubject subject;
  int texture_size = 0;            // of the body atlas (the options' or the automatic one)
  double view_shading = 0;         // the strength in use
  std::vector<SmplxParams> truth;  // true parameters per frame (the dataset's params_true)
  std::vector<SmplxParams> fits;   // truth with the options' fit noise (the dataset's params)
  Camera camera;                   // static, options.size square: the train and test frames'
  std::vector<Camera> unseen_cameras;  // the unseen views' (empty without options.unseen)
  int first_unseen() const { return options.train_frames + options.test_frames; }
  const Camera& frame_camera(int i) const {
    return i >= first_unseen() ? unseen_cameras.at(size_t(i - first_unseen())) : camera;
  }
  double min_pose_gap = 0;  // measured min over (test, train) pairs of pose_distance (0: no test frames)
};

// Validates the options, builds the subject on `body` (which needs vt/ft), its motions,
// fits and camera.
SynthScene make_synth_scene(const BodyModel& body, const SynthOptions& opt);

// The scene of `haha synth --motion`, in two steps so the caller can turn the motion into
// haha's Y-up world about the subject's rest pelvis (subject.rest_joints[0..2]) in between:
// make_synth_subject_scene checks the options (but the frame counts) and builds the subject
// of make_synth_scene (same options, seed and body), without frames; set_synth_scene_motion
// then poses it in `motion` (Y-up; place_synth_motion), every frame a test frame
// (options.train_frames = 0, test_frames = the motion's length), exact fits, the camera of
// synth_camera over the placed frames. Throws haha::Error "motion: no frames" for an empty
// motion.
SynthScene make_synth_subject_scene(const BodyModel& body, const SynthOptions& opt);
void set_synth_scene_motion(const BodyModel& body, SynthScene& scene, const std::vector<SmplxParams>& motion);

// Puts a motion (Y-up, haha's world) on the synthetic subject so a static camera in front of
// it keeps the person framed: each frame keeps its global orientation and every joint
// rotation; its betas become the subject's (the garments are built on that shape), its
// expression is cut or padded with zeros to the subject's; its horizontal translation
// (x, z) is dropped, so the pelvis stays above the rest pelvis (a walk walks on a
// treadmill); its vertical translation keeps the motion's rises and falls, shifted by one
// amount for the whole motion so that the lowest body vertex over all frames touches the
// rest floor (the lowest vertex of the subject's rest body), as the synth frames stand.
std::vector<SmplxParams> place_synth_motion(const BodyModel& body, const SynthSubject& subject,
                                            std::vector<SmplxParams> frames);

// Renders every frame of the scene, supersampled (SynthRenderer::render, all parts), and
// hands them to sink(frame, rgb (H, W, 3) on black, mask (H, W, 1) coverage, garment) in
// frame order, on the calling thread; garment is SynthRenderer::render's garment fraction
// when `garment_masks` is set, else null. Small frames are rendered several at a time,
// large ones one at a time (memory: one supersampled raster). `body` is the scene's.
using SynthFrameSink = std::function<void(int frame, const Image& rgb, const Image& mask, const Image* garment)>;
void render_synth_frames(const BodyModel& body, const SynthScene& scene, bool garment_masks,
                         const SynthFrameSink& sink);
// The same without garment masks.
void render_synth_frames(const BodyModel& body, const SynthScene& scene,
                         const std::function<void(int frame, const Image& rgb, const Image& mask)>& sink);

}  // namespace haha
