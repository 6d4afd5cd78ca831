// `haha motion`: writes a short procedural SMPL-X motion for `haha render --motion`
// (app/motion_run.h).
#include <memory>

#include "app/motion_run.h"
#include "command.h"

HAHA_COMMAND(motion) {
  auto o = std::make_shared<haha::MotionRunOptions>();
  auto* sub = app.add_subcommand("motion", "Write a short procedural SMPL-X motion (AMASS-style .npz) for haha render");
  sub->add_option("--out", o->out, "output .npz (poses (T,165), trans (T,3), mocap_frame_rate)")->required();
  sub->add_option("--kind", o->kind, "wave, walk or turn")->capture_default_str();
  sub->add_option("--frames", o->frames, "number of frames (one loop of the motion)")->capture_default_str();
  sub->add_option("--fps", o->fps, "frame rate stored in the file")->capture_default_str();
  sub->callback([o] { haha::run_motion(*o); });
}
