// `haha motion`'s driver: a procedural motion (synth/demo_motion.h) as an AMASS-style .npz
// (poses (T, 165), trans (T, 3), mocap_frame_rate, up = (0, 1, 0): haha's Y-up world, unlike
// AMASS's Z-up) for `haha render --motion`.
#pragma once

#include <string>

namespace haha {

struct MotionRunOptions {
  std::string out, kind = "wave";
  int frames = 48;  // one loop of the motion
  double fps = 24;  // stored in the file
};

// Writes `out` and prints one line. Throws haha::Error naming the option for bad input.
void run_motion(const MotionRunOptions& options);

}  // namespace haha
