// Rig files for `haha motion --retarget` (app/rig_import.h through Assimp, then the bone
// map chooser and the retargeter): BVH, and glTF / GLB when the bytes say so.
// links: haha_app
#include "app/bone_map.h"
#include "app/motion_retarget.h"
#include "app/rig_import.h"
#include "body/procedural_body.h"
#include "core/atomic_file.h"
#include "fuzz_target.h"

namespace {

std::string extension_of(const uint8_t* data, size_t size) {
  if (size >= 4 && std::equal(data, data + 4, "glTF")) return ".glb";
  if (size >= 1 && data[0] == '{') return ".gltf";
  return ".bvh";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const haha::BodyModel body = haha::make_procedural_body({haha::BodyResolution::low, 0});
  const std::string path = haha::fuzz::as_file(data, size, extension_of(data, size));
  haha::fuzz::expect_result_or_error([&] {
    const haha::RigAnimation rig = haha::read_rig_animation(path);
    const haha::BoneMatch match = haha::choose_bone_map(haha::builtin_bone_maps(), rig.names);
    haha::RetargetOptions o;
    (void)haha::retarget_rig(rig, match, body, o);
  });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  haha::fuzz::write_seed(dir, "cmu_style.bvh", [] {
    const std::string t = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT LeftUpLeg
  {
    OFFSET 9 -5 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT LeftLeg
    {
      OFFSET 0 -42 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      JOINT LeftFoot
      {
        OFFSET 0 -40 0
        CHANNELS 3 Zrotation Yrotation Xrotation
        End Site
        {
          OFFSET 0 -5 12
        }
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET -9 -5 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 -80 0
    }
  }
  JOINT Spine
  {
    OFFSET 0 12 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT Head
    {
      OFFSET 0 50 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 20 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.033333
0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
1 90 2 5 0 0 30 0 0 -40 0 0 10 0 0 -20 0 0 5 0 0 3 0 0
2 91 4 10 0 0 60 0 0 -80 0 0 20 0 0 -30 0 0 10 0 0 6 0 0
)";
    return std::vector<uint8_t>(t.begin(), t.end());
  }());
  haha::fuzz::write_seed(dir, "two_nodes.gltf", [] {
    const std::string t = R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"name":"hips","children":[1,2,3]},{"name":"leftUpperLeg","translation":[0.1,-0.05,0]},
{"name":"rightUpperLeg","translation":[-0.1,-0.05,0]},{"name":"head","translation":[0,0.6,0]}],
"buffers":[{"byteLength":40,"uri":"data:application/octet-stream;base64,AAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAPwAAAAAAAAAA17NdPw=="}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":8},{"buffer":0,"byteOffset":8,"byteLength":32}],
"accessors":[{"bufferView":0,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]},
{"bufferView":1,"componentType":5126,"count":2,"type":"VEC4"}],
"animations":[{"name":"Nod","samplers":[{"input":0,"output":1}],"channels":[{"sampler":0,"target":{"node":3,"path":"rotation"}}]}]})";
    return std::vector<uint8_t>(t.begin(), t.end());
  }());
}
