// `haha render` says how far the legs poke through an avatar's garment over the motion it
// renders (body/garment_clearance.h): on the procedural body with a skirt built as the
// trainer builds one, a high kick gets a thigh through it, a walk's frames are counted the
// same way; an avatar without a garment prints no such line.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "body/garment.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "format/avatar_pack.h"
#include "support/format_test_avatar.h"
#include "support/haha_cli.h"
#include "support/skirt_shape.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

int haha_cli(const std::string& args, const fs::path& dir, std::string* out) { return test::run_haha(args, dir, out); }
std::string q(const fs::path& p) { return test::quoted(p); }

// The procedural body with a skirt from the waist to 80% of the way to the knees.
BodyModel skirted_body() {
  const BodyModel b = make_procedural_body({BodyResolution::low, 0});
  std::vector<float> verts(3 * size_t(b.num_verts)), joints(3 * size_t(kNumJoints));
  Lbs<float>(b).forward(SmplxParams{}, verts.data(), joints.data(), nullptr);
  return append_garment(b, build_garment(b, verts, joints, test::skirt_shape(joints)));
}

struct Line {
  int covered = -1, through = -1, frames = -1, worst_frame = -1;
  double share = -1, deepest_mm = -1;
};

bool parse(const std::string& out, Line* l) {
  const size_t at = out.find("garment: ");
  if (at == std::string::npos) return false;
  return std::sscanf(out.c_str() + at,
                     "garment: %d body vertices inside it at rest; a leg through it in %d of %d frames, at most %lf%% of "
                     "them, deepest %lf mm (frame %d)",
                     &l->covered, &l->through, &l->frames, &l->share, &l->deepest_mm, &l->worst_frame) == 6;
}

TEST(RenderGarmentClearance, AKickGetsAThighThroughTheSkirtAndTheLineSaysHowFar) {
  if (!fs::exists(test::kHaha)) GTEST_SKIP() << "the haha executable is not built at " << test::kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-render-clearance-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Avatar a = test::make_test_avatar(40);
  a.body = skirted_body();
  a.betas.clear();
  a.expression.clear();
  for (int i = 0; i < a.gaussians.size(); ++i) a.gaussians.face[size_t(i)] = (i * 37) % a.body.num_faces;
  PackOptions opt;
  opt.pose_correctives = PoseCorrectives::none;
  write_avatar_glb(a, (dir / "skirt.glb").string(), opt);
  Avatar bare = test::make_test_avatar(40);
  write_avatar_glb(bare, (dir / "bare.glb").string(), opt);

  std::string out;
  for (const char* kind : {"kick", "walk"})
    ASSERT_EQ(haha_cli(std::string("motion --kind ") + kind + " --frames 12 --out " + q(dir / (std::string(kind) + ".npz")), dir, &out), 0)
        << out;
  auto render = [&](const char* avatar, const char* motion) {
    return "render " + q(dir / avatar) + " --motion " + q(dir / motion) + " --size 32 --out " + q(dir / "frames");
  };
  ASSERT_EQ(haha_cli(render("skirt.glb", "kick.npz"), dir, &out), 0) << out;
  Line kick;
  ASSERT_TRUE(parse(out, &kick)) << out;
  EXPECT_GT(kick.covered, 100) << out;
  EXPECT_EQ(kick.frames, 12) << out;
  EXPECT_GT(kick.through, 0) << out;
  EXPECT_GT(kick.deepest_mm, 10.0) << "a thigh raised 80 degrees leaves the skirt: " << out;
  EXPECT_GT(kick.share, 0.0) << out;
  EXPECT_GE(kick.worst_frame, 0);
  EXPECT_LT(kick.worst_frame, 12);

  ASSERT_EQ(haha_cli(render("skirt.glb", "walk.npz"), dir, &out), 0) << out;
  Line walk;
  ASSERT_TRUE(parse(out, &walk)) << out;
  EXPECT_EQ(walk.covered, kick.covered) << "the same rest surface covers the same vertices";
  EXPECT_LT(walk.deepest_mm, kick.deepest_mm) << out;

  ASSERT_EQ(haha_cli(render("bare.glb", "kick.npz"), dir, &out), 0) << out;
  EXPECT_EQ(out.find("garment:"), std::string::npos) << out;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace haha
