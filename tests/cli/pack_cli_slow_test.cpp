// End to end through the `haha` executable: a run directory -> pack -> info -> unpack ->
// repack -> render, and one clear error line for a corrupt file. Skips when the executable
// has not been built next to this test (build/cli/haha).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "format/avatar_npz.h"
#include "format/avatar_unpack.h"
#include "support/format_realistic_avatar.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;

int run(const std::string& args, const fs::path& stdout_file, const fs::path& stderr_file) {
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + stdout_file.string() + "' 2> '" + stderr_file.string() + "'";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

TEST(FormatCli, PackInfoUnpackRepackRender) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-cli-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "run");
  const Avatar a = test::make_realistic_avatar(2000, 64, 5, BodyResolution::low);
  save_body_model(a.body, (dir / "run/body.npz").string());
  save_avatar_npz(a, (dir / "run/avatar.npz").string());
  std::ofstream(dir / "run/config.json") << "{\"model\": \"body.npz\"}\n";
  const fs::path out = dir / "out.txt", err = dir / "err.txt";

  ASSERT_EQ(run("pack '" + (dir / "run").string() + "' --out '" + (dir / "a.glb").string() + "'", out, err), 0) << slurp(err);
  ASSERT_EQ(run("info '" + (dir / "a.glb").string() + "' --json", out, err), 0) << slurp(err);
  const nlohmann::json info = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(info["counts"]["gaussians"].get<int>(), 2000);
  EXPECT_EQ(info["counts"]["faces"].get<int>(), a.body.num_faces);
  EXPECT_EQ(info["storage"]["paperAccountingBytes"].get<size_t>(), 56u * 2000 + 196608);
  EXPECT_TRUE(info["poseCorrectives"]["trainedWith"].get<bool>());
  ASSERT_EQ(run("info '" + (dir / "a.glb").string() + "'", out, err), 0) << slurp(err);
  EXPECT_NE(slurp(out).find("paper's accounting"), std::string::npos);

  ASSERT_EQ(run("unpack '" + (dir / "a.glb").string() + "' --out '" + (dir / "un").string() + "'", out, err), 0) << slurp(err);
  for (const char* f : {"texture.jpg", "mesh.obj", "gaussians.ply", "summary.json", "avatar.npz", "body.npz", "config.json"})
    EXPECT_TRUE(fs::exists(dir / "un" / f)) << f;
  // The unpacked directory is a run directory again: a lossless repack restores exactly
  // what the first file decodes to.
  ASSERT_EQ(run("pack '" + (dir / "un").string() + "' --lossless --out '" + (dir / "b.glb").string() + "'", out, err), 0)
      << slurp(err);
  const Avatar ua = read_avatar_glb((dir / "a.glb").string()), ub = read_avatar_glb((dir / "b.glb").string());
  EXPECT_EQ(ua.gaussians.face, ub.gaussians.face);
  EXPECT_EQ(ua.gaussians.offset, ub.gaussians.offset);
  EXPECT_EQ(ua.gaussians.scale, ub.gaussians.scale);
  EXPECT_EQ(ua.texture.rgb, ub.texture.rgb);
  EXPECT_EQ(ua.body.v_template, ub.body.v_template);

  // An AMASS-style motion of 3 frames, rendered with the body model's pose correctives.
  Npz m;
  std::vector<float> poses(3 * 165, 0.0f), trans(3 * 3, 0.0f);
  for (int t = 0; t < 3; ++t) poses[size_t(t) * 165 + 3 * 16 + 2] = -0.5f * float(t);  // lower the left arm
  m.set("poses", NpyArray::from(poses, {3, 165}));
  m.set("trans", NpyArray::from(trans, {3, 3}));
  m.set("mocap_frame_rate", NpyArray::from(std::vector<double>{30.0}, {}));
  m.write((dir / "motion.npz").string());
  std::string video;
  if (std::system("ffmpeg -version > /dev/null 2>&1") == 0) video = " --video '" + (dir / "m.mp4").string() + "'";
  ASSERT_EQ(run("render '" + (dir / "a.glb").string() + "' --motion '" + (dir / "motion.npz").string() + "' --out '" +
                    (dir / "frames").string() + "' --size 64 --model '" + (dir / "run/body.npz").string() + "'" + video,
                out, err),
            0)
      << slurp(err);
  for (const char* f : {"frame_00000.png", "frame_00001.png", "frame_00002.png"}) EXPECT_TRUE(fs::exists(dir / "frames" / f)) << f;
  if (!video.empty()) {
    EXPECT_GT(fs::file_size(dir / "m.mp4"), 0u);
  }
  EXPECT_EQ(slurp(err).find("warning"), std::string::npos) << slurp(err);  // correctives came from --model

  // Importance tiers: info lists them; --max-gaussians renders from the first tier only.
  ASSERT_EQ(run("pack '" + (dir / "run").string() + "' --lod 2 --out '" + (dir / "lod.glb").string() + "'", out, err), 0) << slurp(err);
  ASSERT_EQ(run("info '" + (dir / "lod.glb").string() + "' --json", out, err), 0) << slurp(err);
  const nlohmann::json lod = nlohmann::json::parse(slurp(out));
  ASSERT_EQ(lod["tiers"].size(), 2u);
  EXPECT_EQ(lod["tiers"][0]["count"].get<int>(), 1000);
  EXPECT_GT(lod["tiers"][0]["psnr"].get<double>(), 10.0);
  for (const char* limit : {"1000", "0"}) {
    ASSERT_EQ(run("render '" + (dir / "lod.glb").string() + "' --motion '" + (dir / "motion.npz").string() + "' --out '" +
                      (dir / ("lod_" + std::string(limit))).string() + "' --size 64 --max-gaussians " + limit + " --model '" +
                      (dir / "run/body.npz").string() + "'",
                  out, err),
              0)
        << slurp(err);
  }
  EXPECT_NE(slurp(dir / "lod_1000/frame_00000.png"), slurp(dir / "lod_0/frame_00000.png"));  // half the Gaussians

  // A corrupt file: exit code 1 and one line naming the file.
  {
    std::string bytes = slurp(dir / "a.glb");
    bytes.resize(bytes.size() / 2);
    std::ofstream(dir / "bad.glb", std::ios::binary) << bytes;
  }
  EXPECT_EQ(run("info '" + (dir / "bad.glb").string() + "'", out, err), 1);
  const std::string e = slurp(err);
  EXPECT_EQ(e.rfind("haha: error: " + (dir / "bad.glb").string() + ": ", 0), 0u) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
