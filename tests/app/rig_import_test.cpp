// Reading rigs through Assimp (app/rig_import.h): frames at the file's rate, takes by name,
// and one error line naming the file for every kind of bad input.
#include "app/rig_import.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "app/motion_retarget_run.h"
#include "core/atomic_file.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/rig_fixture.h"

namespace haha {
namespace {

const char* const kBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT LeftUpLeg
  {
    OFFSET 10 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.04
0 90 0 0 0 0 0 0 0
1 90 0 0 0 0 30 0 0
2 90 0 0 0 0 60 0 0
)";

struct RigImport : ::testing::Test {
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("haha-rig-import-" + std::to_string(::getpid()));
  void SetUp() override { std::filesystem::create_directories(dir); }
  void TearDown() override { std::filesystem::remove_all(dir); }
  std::string file(const std::string& name, const std::string& text) {
    const std::string p = (dir / name).string();
    write_text_file(p, text);
    return p;
  }
};

TEST_F(RigImport, BvhFramesAtItsRate) {
  const RigAnimation r = read_rig_animation(file("a.bvh", kBvh));
  EXPECT_NEAR(r.fps, 25, 1e-6);
  ASSERT_EQ(r.frames.size(), 3u);
  ASSERT_GE(r.names.size(), 2u);
  EXPECT_EQ(r.names[0], "Hips");
  EXPECT_EQ(r.names[1], "LeftUpLeg");
  EXPECT_EQ(r.parents[1], 0);
  EXPECT_NEAR(r.rest[1].t.x, 10, 1e-9);
  EXPECT_NEAR(r.frames[2][0].t.x, 2, 1e-6);
  // Frame 1: the thigh turned 30 degrees about z (its first channel).
  const Mat3<double> R = r.frames[1][1].m;
  EXPECT_NEAR(R.a[1][1], std::cos(M_PI / 6), 1e-6);
  EXPECT_NEAR(R.a[1][0], std::sin(M_PI / 6), 1e-6);
  EXPECT_NEAR(R.a[2][2], 1, 1e-6);
}

TEST_F(RigImport, TakesByName) {
  const RestSkeleton rest = rest_skeleton(test::low_body());
  Motion m;
  m.frames.resize(3);
  const test::Rig rig = test::make_rig(m, rest, {{"Hips", 0, -1}, {"LeftUpLeg", 1, 0}, {"RightUpLeg", 2, 0}}, 0, 0, 1);
  const std::string glb = (dir / "r.glb").string();
  test::write_rig_glb(rig, glb, "Run");
  EXPECT_EQ(read_rig_animation(glb, "Run").take, "Run");
  EXPECT_EQ(read_rig_animation(glb).take, "Run");
  test::expect_error_at(glb, [&] { read_rig_animation(glb, "Walk"); }, {"no take 'Walk'", "'Run'"});
}

TEST_F(RigImport, BadInputIsOneLineNamingTheFile) {
  const std::string missing = (dir / "missing.bvh").string();
  test::expect_error_at(missing, [&] { read_rig_animation(missing); }, {"cannot read"});
  const std::string junk = file("junk.bvh", "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 zero 0\n");
  test::expect_error_at(junk, [&] { read_rig_animation(junk); }, {"cannot read"});
  const std::string fbx = file("junk.fbx", std::string("Kaydara FBX Binary  \0\x1a\0garbage", 30));
  test::expect_error_at(fbx, [&] { read_rig_animation(fbx); }, {});
  // A glTF with a skeleton but no animation.
  const std::string still = file("still.gltf", R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
    "nodes":[{"name":"Hips","children":[1]},{"name":"LeftUpLeg","translation":[0.1,0,0]}]})");
  test::expect_error_at(still, [&] { read_rig_animation(still); }, {"no animation"});
}

TEST_F(RigImport, RetargetRunRejectsWhatItCannotMap) {
  MotionRetargetOptions o;
  o.out = (dir / "m.npz").string();
  o.in = file("odd.bvh", std::string(kBvh).replace(std::string(kBvh).find("LeftUpLeg"), 9, "Tentacle").replace(std::string(kBvh).find("Hips"), 4, "Body"));
  test::expect_error_at(o.in, [&] { run_motion_retarget(o, test::low_body()); }, {"no bone name matches", "--map"});
  o.in = file("legs.bvh", kBvh);  // hips and one thigh: no left-right pair to tell the axes
  test::expect_error_at(o.in, [&] { run_motion_retarget(o, test::low_body()); }, {"left-right pair"});
  o.map = file("map.json", R"({"Hips": "pelvis", "LeftUpLeg": "left_thigh"})");
  test::expect_error_at(o.map + ": LeftUpLeg", [&] { run_motion_retarget(o, test::low_body()); }, {"not an SMPL-X joint name"});
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

}  // namespace
}  // namespace haha
