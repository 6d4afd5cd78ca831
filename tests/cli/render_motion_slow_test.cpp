// `haha render --motion` with an AMASS-style file: poses (T, 165), trans, mocap_frame_rate
// 120 and AMASS's Z-up world. It must render the body upright and facing the default front
// camera, exactly as the same pose written in haha's Y-up world, and the video must follow
// the mocap rate (or the --rate it was resampled to).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "body/rotation.h"
#include "format/avatar_loader.h"
#include "format/avatar_npz.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/format_realistic_avatar.h"
#include "train/losses.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using V3 = Vec3<double>;

using haha::test::kHaha;
using haha::test::slurp;

int run(const std::string& args, const fs::path& dir) {
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + (dir / "out.txt").string() + "' 2> '" +
                          (dir / "err.txt").string() + "'";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

// PSNR of the RGB channels of two PNGs of one size.
double png_psnr(const fs::path& a, const fs::path& b) {
  const Image x = read_image(a.string()), y = read_image(b.string());
  EXPECT_EQ(x.width, y.width);
  EXPECT_EQ(x.height, y.height);
  if (x.width != y.width || x.height != y.height || x.channels < 3 || y.channels < 3) return 0;
  std::vector<float> rx, ry;
  for (size_t p = 0; p < size_t(x.width) * size_t(x.height); ++p)
    for (int c = 0; c < 3; ++c) rx.push_back(x.data[p * size_t(x.channels) + size_t(c)]), ry.push_back(y.data[p * size_t(y.channels) + size_t(c)]);
  return psnr(rx.data(), ry.data(), x.height, x.width);
}

double video_seconds(const fs::path& mp4, const fs::path& dir) {
  const fs::path out = dir / "probe.txt";
  const std::string cmd = "ffprobe -v error -show_entries format=duration -of default=nw=1:nk=1 '" + mp4.string() +
                          "' > '" + out.string() + "'";
  if (std::system(cmd.c_str()) != 0) return -1;
  return std::atof(slurp(out).c_str());
}

TEST(RenderMotionCli, AmassZUpRendersUprightFacingTheCameraAtTheMocapRate) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-render-motion-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "run");
  const Avatar a = test::make_realistic_avatar(1500, 64, 9, BodyResolution::low);
  save_body_model(a.body, (dir / "run/body.npz").string());
  save_avatar_npz(a, (dir / "run/avatar.npz").string());
  std::ofstream(dir / "run/config.json") << "{\"model\": \"body.npz\"}\n";
  ASSERT_EQ(run("pack '" + (dir / "run").string() + "' --out '" + (dir / "a.glb").string() + "'", dir), 0)
      << slurp(dir / "err.txt");

  // The avatar's rest pelvis J0 (posed pelvis at zero pose and transl).
  const AvatarLoader rt = AvatarLoader::load((dir / "a.glb").string());
  PosedAvatar posed;
  rt.repose(SmplxParams{}, posed);
  const V3 J0(posed.joints[0], posed.joints[1], posed.joints[2]);

  // The same motion twice: in haha's Y-up world (arms lowered, turning a little, stepping
  // sideways) and as AMASS stores it, Z-up: root Rx(+90) * root, trans such that the
  // posed pelvis R^T (J0 + t_y) = J0 + t_z.
  const int T = 25;  // 0.2 s at 120 fps
  const Mat3<double> Rzy = rodrigues(V3(M_PI / 2, 0, 0));  // Y-up world -> Z-up world
  std::vector<double> yup(T * 165, 0.0), zup(T * 165, 0.0), ty(T * 3, 0.0), tz(T * 3, 0.0);
  for (int t = 0; t < T; ++t) {
    double* py = &yup[size_t(t) * 165];
    py[1] = 0.3 * t / T;  // turning about the vertical
    py[3 * 16 + 2] = -1.3;  // left arm down
    py[3 * 17 + 2] = 1.3;   // right arm down
    std::copy(py, py + 165, &zup[size_t(t) * 165]);
    const V3 root = matrix_to_axis_angle(Rzy * rodrigues(V3(py[0], py[1], py[2])));
    for (int c = 0; c < 3; ++c) zup[size_t(t) * 165 + size_t(c)] = root[c];
    const V3 t_y(0.2 * t / T, 0.05, 0.0);
    const V3 t_z = Rzy * (J0 + t_y) - J0;
    for (int c = 0; c < 3; ++c) ty[size_t(t) * 3 + size_t(c)] = t_y[c], tz[size_t(t) * 3 + size_t(c)] = t_z[c];
  }
  Npz amass;
  amass.set("poses", NpyArray::from(zup, {T, 165}));
  amass.set("trans", NpyArray::from(tz, {T, 3}));
  amass.set("betas", NpyArray::from(std::vector<double>(16, 0.0), {16}));
  amass.set("gender", NpyArray::text("neutral"));
  amass.set("mocap_frame_rate", NpyArray::from(std::vector<double>{120.0}, {}));
  amass.write((dir / "amass_stageii.npz").string());
  Npz native;
  native.set("poses", NpyArray::from(yup, {T, 165}));
  native.set("trans", NpyArray::from(ty, {T, 3}));
  native.set("mocap_frame_rate", NpyArray::from(std::vector<double>{120.0}, {}));
  native.set("up", NpyArray::from(std::vector<double>{0, 1, 0}, {3}));
  native.write((dir / "yup.npz").string());

  const bool ffmpeg = std::system("ffmpeg -version > /dev/null 2>&1") == 0;
  auto render = [&](const std::string& motion, const std::string& out, const std::string& extra) {
    const std::string video = ffmpeg ? " --video '" + (dir / (out + ".mp4")).string() + "'" : "";
    ASSERT_EQ(run("render '" + (dir / "a.glb").string() + "' --motion '" + (dir / motion).string() + "' --out '" +
                      (dir / out).string() + "' --size 96 --camera '" + (dir / "cam.json").string() + "'" + video + extra,
                  dir),
              0)
        << slurp(dir / "err.txt");
  };
  // A fixed front camera (the default one frames each motion; this keeps both identical).
  std::ofstream(dir / "cam.json") << R"({"width": 96, "height": 96, "K": [[130, 0, 48], [0, 130, 48], [0, 0, 1]],
    "world_to_camera": [[1, 0, 0, -0.1], [0, -1, 0, -0.35], [0, 0, -1, 3.0], [0, 0, 0, 1]]})";
  render("amass_stageii.npz", "amass", "");
  render("yup.npz", "yup", "");
  for (int t = 0; t < T; t += 8) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", t);
    EXPECT_GT(png_psnr(dir / "amass" / name, dir / "yup" / name), 40.0) << name;
    const Image za = read_image((dir / "amass" / name).string());
    // Upright in the image: the body's covered rows span more than its columns, and its
    // top rows (head) are narrower than its widest row (arms down, hips).
    int top = za.height, bottom = -1, left = za.width, right = -1;
    for (int y = 0; y < za.height; ++y)
      for (int x = 0; x < za.width; ++x) {
        const float* px = &za.data[size_t(y * za.width + x) * size_t(za.channels)];
        if (px[0] + px[1] + px[2] < 2.9f) top = std::min(top, y), bottom = std::max(bottom, y), left = std::min(left, x), right = std::max(right, x);
      }
    ASSERT_GE(bottom, 0) << name << ": nothing rendered";
    EXPECT_GT(bottom - top, 1.3 * (right - left)) << name << ": the body is not upright";
  }
  // A lying body would not match: the AMASS file read as if it were Y-up.
  Npz lying = amass;
  lying.set("up", NpyArray::from(std::vector<double>{0, 1, 0}, {3}));
  lying.write((dir / "lying.npz").string());
  render("lying.npz", "lying", "");
  EXPECT_LT(png_psnr(dir / "lying/frame_00000.png", dir / "yup/frame_00000.png"), 20.0);

  // Timing: 25 frames at 120 fps as stored; resampled to 30 fps: 7 frames (0, 4, ..., 24).
  render("amass_stageii.npz", "amass30", " --rate 30");
  EXPECT_TRUE(fs::exists(dir / "amass30/frame_00006.png"));
  EXPECT_FALSE(fs::exists(dir / "amass30/frame_00007.png"));
  EXPECT_GT(png_psnr(dir / "amass30/frame_00002.png", dir / "amass/frame_00008.png"), 40.0);
  if (ffmpeg) {
    EXPECT_NEAR(video_seconds(dir / "amass.mp4", dir), 25.0 / 120.0, 0.02);
    EXPECT_NEAR(video_seconds(dir / "amass30.mp4", dir), 7.0 / 30.0, 0.02);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
