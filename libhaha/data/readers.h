// Readers for the data formats users have (docs/method.md section 6), each
// converting to the native Dataset (data/dataset.h); motions are io/motion.h.
// Readers validate every file of the selected frames before returning (missing frames,
// mismatched counts between images / masks / parameters, wrong array shapes, unreadable
// images, non-finite values): each problem is one haha::Error naming the offending file.
// Pixels are produced later, frame by frame, through Dataset::loader (decode, mask, crop,
// resize), so converting long videos does not hold every frame in memory.
//
// Source intrinsics put pixel centres at integers (OpenCV); the Dataset's cameras put them
// at +0.5 (core/camera.h), so cx, cy gain 0.5. Crops subtract the crop origin from
// cx, cy; resizing by s scales fx, fy, cx, cy by s (exact in the pixel-edge convention).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"
#include "data/dataset.h"

namespace haha {

// Python-style slice of frame indices [start, end) step `step`; end < 0 = to the end.
// Like Python, an end beyond the available frames is clipped.
struct FrameRange {
  int start = 0, end = -1, step = 1;
  std::vector<int> indices(int available) const;
  std::string str() const;  // "start:end:step"
};
// "start:end:step", "start:end" or "start:" (throws naming `where`).
FrameRange parse_frame_range(const std::string& s, const std::string& where);

struct ConvertOptions {
  int max_side = 0;                  // > 0: resize so the longer side has this many pixels
  int every = 1;                     // keep every k-th frame (X-Humans takes, SMPLify-X folders)
  int max_frames = 0;                // > 0: at most this many frames per take / split
  const BodyModel* model = nullptr;  // for PCA hand poses and a non-flat hand mean
  bool flat_hand_mean = true;        // false: add the model's hands_mean to hand poses
  double fps = 30;
  std::string gender;                // empty: from the data when it says, else neutral
};

// X-Humans takes: TAKE/render/image/color_%06d.png, TAKE/render/depth/depth_%06d.tiff,
// TAKE/render/cameras.npz (intrinsic (3, 3), extrinsic (N, 4, 4) world -> camera, N =
// number of frames, row i = i-th frame in frame-number order), TAKE/SMPLX/mesh-f%05d_smplx.pkl
// (dict of 1-D arrays: global_orient 3, transl 3, body_pose 63, left/right_hand_pose 45
// (or PCA with a model), jaw/leye/reye_pose 3, expression, betas; (1, D) accepted).
// Mask: depth.max() - depth > depth_threshold (the release's rule, depth as stored).
// square_crop: centre square crop as in the release. Gender: a gender.txt in the take's
// parent (subject) folder, if present. Frames of train_takes are "train", of test_takes "test".
struct XHumansOptions : ConvertOptions {
  std::vector<std::string> train_takes, test_takes;
  bool square_crop = true;
  float depth_threshold = 700.0f;
};
Dataset read_xhumans(const XHumansOptions& opt);

// PeopleSnapshot as preprocessed by InstantAvatar: DIR/cameras.npz (intrinsic (3, 3),
// extrinsic (4, 4) world -> camera, height, width), DIR/images/image_%04d.png,
// DIR/masks/mask_%04d.npy ((H, W) bool / uint8 / float), DIR/poses/anim_nerf_{train,test}.npz
// (SMPL: betas (1, 10) or (10,), global_orient (N, 3), body_pose (N, 69) (or (N, 63)), transl (N, 3)),
// row i of a split = i-th frame of its FrameRange over the sorted images. The poses are
// SMPL fits: SMPL and SMPL-X differ in template and root joint, so their numbers are never
// copied into SMPL-X. Every selected frame's SMPL parameters (io/smpl_model_io.h
// smpl_params layout: SMPL joints 22/23 in slots 25/40; (N, 63) body poses leave them at
// rest; the file's betas) go to `fit_smpl` in frame order, which returns their SMPL-X
// parameters (fit/smpl_fit.h does it with the user's SMPL and SMPL-X models). Without
// `fit_smpl` the reader refuses, naming the missing SMPL model. The val split is not read.
struct PeopleSnapshotOptions : ConvertOptions {
  std::string dir;
  FrameRange train{0, 456, 4}, test{456, 676, 4};  // InstantAvatar's male-3-casual split
  std::function<std::vector<SmplxParams>(const std::vector<SmplxParams>& smpl, const std::vector<int>& source_frames)>
      fit_smpl;
};
Dataset read_peoplesnapshot(const PeopleSnapshotOptions& opt);

// SMPLify-X style per-frame pickles: DIR/images/<stem>.{png,jpg,jpeg}, DIR/masks/<stem>.{png,npy}
// and one pickle per image, either DIR/results/<stem>/000.pkl (SMPLify-X's output tree) or
// DIR/smplx/<stem>.pkl. Pickle keys: the SMPL-X parameter names ((1, D) or (D,); hands full
// 45 or PCA coefficients, which need `model`; body_pose 63 (a 32-value VPoser code is an
// error)), camera_rotation (3, 3), camera_translation (3), optional camera_focal_length_x/_y
// (or focal_length) and camera_center (2) in pixels; else `focal` and the image centre, as
// SMPLify-X assumes. SMPLify-X fits usually use a non-flat hand mean (its default): pass
// flat_hand_mean = false with a model then. Frames: `train` / `test` ranges over the
// sorted images (default: all frames train).
struct SmplifyxOptions : ConvertOptions {
  std::string dir;
  double focal = 5000.0;
  FrameRange train{0, -1, 1};
  FrameRange test{0, 0, 1};  // empty
};
Dataset read_smplifyx(const SmplifyxOptions& opt);

// Shared by the readers: the SMPL-X parameters of one fit dict (pickle). `where` names the
// file in errors. Missing pose groups are zero; global_orient and body_pose are required.
class Pickle;
SmplxParams smplx_params_from_pickle(const Pickle& p, const ConvertOptions& opt);

}  // namespace haha
