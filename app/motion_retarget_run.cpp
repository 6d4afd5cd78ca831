#include "app/motion_retarget_run.h"

#include <cstdio>

#include "app/motion_from_fit.h"
#include "app/motion_retarget_check.h"
#include "body/joint_names.h"
#include "body/rest_skeleton.h"
#include "core/error.h"
#include "io/motion_bvh.h"

namespace haha {

// A rig's rest torso further than this from SMPL-X's is not a standing rest: worth a warning.
constexpr double kRestTorsoWarnDeg = 20;

void run_motion_retarget(const MotionRetargetOptions& o, const BodyModel& body) {
  if (!(o.fps >= 0 && o.fps <= 1000)) fail("--fps", "must be in (0, 1000]");
  // The map first: a bad map file fails before the (possibly long) clip is read.
  std::vector<BoneMap> maps;
  if (o.map.empty()) maps = builtin_bone_maps();
  else maps.push_back(read_bone_map(o.map));
  const RigAnimation rig = read_rig_animation(o.in, o.take);
  std::printf("%s: take '%s', %zu frames at %g fps, %zu nodes\n", o.in.c_str(), rig.take.c_str(), rig.frames.size(), rig.fps,
              rig.names.size());
  const BoneMatch match = choose_bone_map(maps, rig.names);
  if (match.matched == 0) fail(o.in, "no bone name matches map '" + match.map + "': give --map MAP.json");
  RetargetReport rep;
  Motion m = retarget_rig(rig, match, body, o.retarget, &rep);
  std::string rest;
  for (int j : rep.at_rest) rest += (rest.empty() ? "" : ", ") + std::string(kSmplxJointNames[j]);
  std::printf("map '%s': %d of %d SMPL-X joints matched (%zu of 22 body joints); at rest: %s; the rig's rest torso %.1f deg "
              "from SMPL-X's\n",
              match.map.c_str(), match.matched, kNumJoints, 22 - rep.at_rest.size(), rest.empty() ? "none" : rest.c_str(),
              rep.rest_torso_deg);
  if (rep.rest_torso_deg > kRestTorsoWarnDeg)
    std::printf("warning: %s: the rig's rest pose leans %.0f deg from a standing one (pelvis to neck): the torso, neck and "
                "head follow the rig's turns from that rest and lean with it; the file's node transforms are not its "
                "standing bind pose (an animation exported without its rig's rest?)\n",
                o.in.c_str(), rep.rest_torso_deg);
  std::printf("%s\n", retarget_check_line(check_retarget(rig, match, m, rest_skeleton(body), rep, o.retarget.contacts)).c_str());
  if (o.fps > 0 && o.fps != m.fps) m = resample_motion(m, o.fps);
  write_motion_npz(m, o.out);
  std::printf("%s: %zu frames at %g fps, root path scaled by %.4g, %d foot contacts held\n", o.out.c_str(), m.frames.size(), m.fps,
              rep.scale, rep.contacts);
}

void run_motion_to_bvh(const std::string& in, const std::string& out, const BodyModel& body) {
  Motion m = read_motion(in, &body);
  const RestSkeleton rest = rest_skeleton(body);
  motion_to_y_up(m, {rest.joints[0].x, rest.joints[0].y, rest.joints[0].z});
  write_motion_bvh(m, rest, out);
  std::printf("%s: %zu frames at %g fps, %d joints, centimetres, Y up, floor at y = 0\n", out.c_str(), m.frames.size(), m.fps,
              kNumJoints);
}

}  // namespace haha
