// The native dataset: a monocular video with masks, cameras and per-frame SMPL-X fits.
// `haha synth` writes it, `haha convert` turns real data into it, `haha train` reads it.
//
// On disk (DIR):
//   dataset.json             description (below)
//   images/%06d.png          RGB frames, 8-bit, frame i of the frame list
//   masks/%06d.png           person masks, 8-bit single channel (255 = person)
//   smplx/params.npz         SMPL-X fits, arrays (N, D) named as in SMPL-X fitting code:
//                            global_orient 3, body_pose 63, jaw_pose 3, leye_pose 3,
//                            reye_pose 3, left_hand_pose 45, right_hand_pose 45 (full
//                            axis-angle, hand mean already included), betas, expression,
//                            transl 3 (io/smplx_params_io.h)
//   smplx/params_true.npz    optional: true parameters (synthetic data with perturbed fits)
//
// dataset.json, version 1:
//   {"format": "haha-dataset", "version": 1,
//    "width": W, "height": H, "fps": 30, "gender": "neutral" | "male" | "female",
//    "source": "free text: what this was made or converted from",
//    "source_crop": [x0, y0, w, h],   (optional) the frames are this box of the source's frames
//                     (source pixels, w x h = width x height, not scaled): source pixel
//                     (u, v) is pixel (u - x0, v - y0) here, and cx, cy are shifted alike
//    "premultiplied": true | false,   (optional) images composited on black with the soft
//                     mask (rgb = mask x colour); absent: not known (older files)
//    "fits": "exact" | "estimated",   (optional) the SMPL-X fits are the true parameters (or
//                     registered to 3D scans) or estimated from the images, off by a few
//                     degrees and centimetres; absent: not known (older files), trained as exact
//    "camera": {"K": [[fx,0,cx],[0,fy,cy],[0,0,1]], "world_to_camera": 4x4, "near": n, "far": f},
//    "smplx": "smplx/params.npz", "smplx_true": "smplx/params_true.npz",   (the latter optional)
//    "frames": [{"image": "images/000000.png", "mask": "masks/000000.png",
//                "split": "train" | "test" | "unseen", "source_index": 17,   (optional)
//                "camera": {...}}, ...]}                       (per frame, when not static)
// The top-level "camera" applies to every frame without its own. Cameras follow
// core/camera.h: OpenCV axes, world-to-camera extrinsics, pixel (i, j) covers
// [i, i+1) x [j, j+1) so its centre is (i + 0.5, j + 0.5). Intrinsics of sources that put
// pixel centres at integers (OpenCV, most datasets) are converted by adding 0.5 to cx, cy.
// Row i of the npz files belongs to frame i of the list. Paths are relative to DIR.
//
// Reading validates everything before returning (missing or unreadable files, image sizes,
// counts of frames / masks / parameter rows, array shapes, non-finite values): each
// problem is one haha::Error line naming the offending file. Writing goes to a temporary
// directory renamed into place at the end, so a failed write leaves nothing behind.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "body/smplx_params.h"
#include "io/image.h"
#include "core/camera.h"

namespace haha {

// train: the frames `haha train` learns from; test: held-out frames (novel poses);
// unseen: views the training video never showed (`haha synth --unseen`: from below the chin,
// from above the head, arms raised), scored by `haha eval --split unseen`, never trained on.
enum class Split { train, test, unseen };
const char* split_name(Split s);
Split parse_split(const std::string& s, const std::string& where);  // "train" | "test" | "unseen"

// "fits" of dataset.json: how close the SMPL-X fits are to the person in the images.
// `haha train` picks the settings for estimated fits by it (train/config.h, key `fits`).
enum class Fits { unknown, exact, estimated };
const char* fits_name(Fits f);  // "" (unknown), "exact", "estimated"
Fits parse_fits(const std::string& s, const std::string& where);  // "exact" | "estimated"

struct DatasetFrame {
  Split split = Split::train;
  Camera camera;              // width/height equal the dataset's
  SmplxParams params;         // the fit used for training
  int source_index = -1;      // frame number in the data it came from (informative)
  std::string image_path;     // file the pixels come from (empty for frames made in memory)
  std::string mask_path;
  Image image;                // RGB (H, W, 3) in [0, 1]; empty until loaded
  Image mask;                 // (H, W, 1) in [0, 1], 1 = person; empty until loaded
};

struct Dataset {
  std::string path;           // directory (or source) it was read from, for messages
  int width = 0, height = 0;
  double fps = 30;
  std::string gender = "neutral";
  std::string source;
  // "premultiplied" of dataset.json: -1 not given, 0 false, 1 true.
  int premultiplied = -1;
  // "source_crop" of dataset.json: x0, y0, w, h in the source's pixels; w = 0: not given.
  std::array<int, 4> source_crop{};
  Fits fits = Fits::unknown;  // "fits" of dataset.json
  std::vector<DatasetFrame> frames;
  std::vector<SmplxParams> params_true;  // empty, or one per frame

  // Produces the pixels of frame i (decode, crop, resize, mask from depth ...). Readers
  // install it; frames made in memory need none. Throws haha::Error naming the file.
  std::function<void(int i, Image& rgb, Image& mask)> loader;

  // Fills frames[i].image / .mask through `loader` when empty; checks sizes and channels.
  void load_frame(int i);
  void load_all();  // every frame, in parallel; the first error (by frame order) is thrown
  void unload_frame(int i);
  std::vector<int> indices(Split s) const;
  bool is_static_camera() const;
};

enum class LoadPixels {
  all,      // decode every image and mask now
  headers,  // open every image and mask and check its size now; decode on load_frame()
};

// Reads and validates DIR (see above).
Dataset read_dataset(const std::string& dir, LoadPixels load = LoadPixels::all);

// Streams a dataset to disk: frames go to DIR.tmp-<pid>/ and the directory is renamed to
// DIR by finish(). A writer destroyed before finish() (an exception) removes its temporary
// directory. An existing DIR is replaced only if it is empty or a haha dataset.
class DatasetWriter {
 public:
  DatasetWriter(std::string dir, int width, int height, double fps, std::string gender, std::string source);
  ~DatasetWriter();
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  // Appends a frame: writes images/%06d.png and masks/%06d.png. `rgb` has 3 channels
  // (4: alpha dropped), `mask` 1 channel, both width x height; camera size must match;
  // parameters finite. `truth` (optional) is the frame's true SMPL-X parameters: give it
  // for all frames or for none.
  void add(const DatasetFrame& frame, const Image& rgb, const Image& mask, const SmplxParams* truth = nullptr);
  // "premultiplied" of dataset.json (Dataset::premultiplied); -1 (the default) writes nothing.
  void set_premultiplied(int flag);
  // "source_crop" of dataset.json (Dataset::source_crop): x0, y0 >= 0, w x h the dataset's size.
  void set_source_crop(int x0, int y0, int w, int h);
  // "fits" of dataset.json (Dataset::fits); unknown (the default) writes nothing.
  void set_fits(Fits fits);
  // Writes the npz files and dataset.json and moves the directory into place.
  void finish();
  int num_frames() const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

// Writes a whole Dataset (pixels from the frames, or through its loader when empty).
void write_dataset(const Dataset& ds, const std::string& dir);

}  // namespace haha
