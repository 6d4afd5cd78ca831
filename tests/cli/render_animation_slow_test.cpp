// `haha pack --animation` then `haha render --animation`: the file's own animation renders
// as the motion it was packed from does through `haha render --motion` (one render path;
// the difference is the 16-bit rotations), and `haha info` lists it.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "format/avatar_npz.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/format_realistic_avatar.h"
#include "support/haha_cli.h"
#include "train/losses.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

int run(const std::string& args, const fs::path& dir) {
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + (dir / "out.txt").string() + "' 2> '" +
                          (dir / "err.txt").string() + "'";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

double png_psnr(const fs::path& a, const fs::path& b) {
  const Image x = read_image(a.string()), y = read_image(b.string());
  if (x.width != y.width || x.height != y.height || x.channels < 3 || y.channels < 3) return 0;
  std::vector<float> rx, ry;  // (H, W, 3), as psnr() takes them
  for (size_t p = 0; p < size_t(x.width) * size_t(x.height); ++p)
    for (int c = 0; c < 3; ++c) rx.push_back(x.data[p * size_t(x.channels) + size_t(c)]), ry.push_back(y.data[p * size_t(y.channels) + size_t(c)]);
  return psnr(rx.data(), ry.data(), x.height, x.width);
}

TEST(RenderAnimationCli, TheFilesAnimationRendersAsItsMotion) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-render-animation-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "run");
  const Avatar a = test::make_realistic_avatar(1500, 64, 9, BodyResolution::low);
  save_body_model(a.body, (dir / "run/body.npz").string());
  save_avatar_npz(a, (dir / "run/avatar.npz").string());
  std::ofstream(dir / "run/config.json") << "{\"model\": \"body.npz\"}\n";
  ASSERT_EQ(run("motion --out '" + (dir / "wave.npz").string() + "' --kind wave --frames 12 --fps 24", dir), 0) << slurp(dir / "err.txt");
  ASSERT_EQ(run("pack '" + (dir / "run").string() + "' --out '" + (dir / "a.glb").string() + "' --animation '" +
                    (dir / "wave.npz").string() + "' --animation-name hello",
                dir),
            0)
      << slurp(dir / "err.txt");
  ASSERT_EQ(run("info '" + (dir / "a.glb").string() + "'", dir), 0);
  EXPECT_NE(slurp(dir / "out.txt").find("'hello': 0.458 s, 12 frames at 24 fps"), std::string::npos) << slurp(dir / "out.txt");
  std::ofstream(dir / "cam.json") << R"({"width": 96, "height": 96, "K": [[130, 0, 48], [0, 130, 48], [0, 0, 1]],
    "world_to_camera": [[1, 0, 0, 0], [0, -1, 0, -0.35], [0, 0, -1, 3.0], [0, 0, 0, 1]]})";
  const std::string common = " --out '%s' --size 96 --camera '" + (dir / "cam.json").string() + "'";
  auto render = [&](const std::string& source, const std::string& out) {
    char tail[1024];
    std::snprintf(tail, sizeof tail, common.c_str(), (dir / out).string().c_str());
    ASSERT_EQ(run("render '" + (dir / "a.glb").string() + "' " + source + tail, dir), 0) << slurp(dir / "err.txt");
  };
  render("--animation hello", "anim");
  render("--motion '" + (dir / "wave.npz").string() + "'", "motion");
  for (int t = 0; t < 12; ++t) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", t);
    ASSERT_TRUE(fs::exists(dir / "anim" / name)) << name;
    EXPECT_GT(png_psnr(dir / "anim" / name, dir / "motion" / name), 40.0) << name;
  }
  EXPECT_FALSE(fs::exists(dir / "anim" / "frame_00012.png"));
  EXPECT_EQ(run("render '" + (dir / "a.glb").string() + "' --animation wave --out '" + (dir / "x").string() + "'", dir), 1);
  const std::string err = slurp(dir / "err.txt");
  EXPECT_EQ(err.rfind("haha: error: " + (dir / "a.glb").string() + ": no animation 'wave'", 0), 0u) << err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
