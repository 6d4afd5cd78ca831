// `haha render`: repose a packed avatar with a motion (AMASS-style or native SMPL-X
// parameters, or the file's own glTF animation sampled at its rate, format/animation.h; AMASS's Z-up world is turned to Y-up about the avatar's rest pelvis, and the
// motion optionally resampled, io/motion.h) and render every frame with the merged mesh + Gaussian renderer
// (format/avatar_loader.h) to DIR/frame_%05d.png, optionally encoding an mp4 with the
// ffmpeg command-line tool.
#pragma once

#include <string>

namespace haha {

struct RenderRunOptions {
  std::string avatar;         // .glb
  int max_gaussians = 0;      // > 0: load only the importance tiers that fit (pack --lod)
  std::string motion;         // AMASS-style motion .npz, or
  std::string params;         // a native SMPL-X parameter file, or
  std::string animation;      // the name or index of one of the avatar's glTF animations
  std::string out;            // directory for frame_%05d.png
  std::string camera;         // cam.json; empty: a front camera framing the whole motion
  std::string video;          // also encode an .mp4 (ffmpeg) when set
  std::string model;          // body model: pose correctives (and PCA hands) when the file has none
  float background[3] = {1, 1, 1};
  int size = 512;             // image side of the default camera
  int every = 1, max_frames = 0;
  double rate = 0;            // resample the motion to this many frames per second (0: keep its own rate)
  double fps = 0;             // video rate; 0: the motion's rate (after --rate) / every
};

// Throws haha::Error naming the file or option for bad input.
void run_render(const RenderRunOptions& o);

}  // namespace haha
