#include "app/motion_run.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "body/body_model.h"
#include "core/error.h"
#include "io/npy.h"
#include "synth/demo_motion.h"

namespace haha {

void run_motion(const MotionRunOptions& o) {
  if (o.frames < 1 || o.frames > 100000) fail("--frames", "must be in 1..100000");
  if (!(o.fps > 0 && o.fps <= 1000)) fail("--fps", "must be in (0, 1000]");
  demo_motion_pose(o.kind, 0.0);  // rejects an unknown kind before any work
  const size_t T = size_t(o.frames);
  std::vector<float> poses(T * kNumPoseValues), trans(T * 3, 0.0f);
  for (size_t t = 0; t < T; ++t) {
    const std::vector<float> p = demo_motion_pose(o.kind, double(t) / double(T));
    std::copy(p.begin(), p.end(), poses.begin() + long(t * kNumPoseValues));
  }
  Npz z;
  z.set("poses", NpyArray::from(poses, {int64_t(T), kNumPoseValues}));
  z.set("trans", NpyArray::from(trans, {int64_t(T), 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{o.fps}, {}));
  // Written in haha's Y-up world; without `up` readers take AMASS's Z-up (io/motion.h).
  z.set("up", NpyArray::from(std::vector<float>{0, 1, 0}, {3}));
  z.write(o.out);
  std::printf("%s: %zu frames of '%s' at %g fps\n", o.out.c_str(), T, o.kind.c_str(), o.fps);
}

}  // namespace haha
