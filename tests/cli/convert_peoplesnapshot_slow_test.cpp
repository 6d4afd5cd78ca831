// `haha convert --from peoplesnapshot` end to end: an InstantAvatar-layout folder whose poses
// are SMPL fits of an SMPL-layout stand-in (body/smpl_standin.h: known template shift and
// shape). Without --smpl-model: exit 1, one line naming the missing SMPL model. With the
// stand-in and the SMPL-X model: per-frame residuals under 5 mm and the known offsets
// recovered in the converted dataset.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "body/procedural_body.h"
#include "body/smpl_standin.h"
#include "data/dataset.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/smpl_model_io.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

TEST(ConvertPeopleSnapshotCli, FitsSmplxToSmplAndRefusesWithoutTheSmplModel) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-convert-ps-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const fs::path ps = dir / "male-3-casual";
  for (const char* sub : {"images", "masks", "poses"}) fs::create_directories(ps / sub);

  const BodyModel smplx = make_procedural_body({BodyResolution::low, 2});
  save_body_model(smplx, (dir / "smplx.npz").string());
  SmplStandinOptions so;
  so.betas = {0.5f, -0.4f, 0.3f};
  so.shift = {-0.015f, 0.022f, 0.01f};
  std::vector<int32_t> corr;
  save_smpl_model(make_smpl_standin(smplx, so, &corr), (dir / "smpl.npz").string());
  Npz c;
  c.set("smpl_to_smplx", NpyArray::from(corr, {int64_t(corr.size())}));
  c.write((dir / "corr.npz").string());

  const int W = 16, H = 12, frames = 6;
  for (int i = 0; i < frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "image_%04d.png", i);
    Image img(W, H, 3);
    for (size_t k = 0; k < img.data.size(); ++k) img.data[k] = float((k * 7 + size_t(i)) % 11) / 10.0f;
    write_image((ps / "images" / name).string(), img);
    std::snprintf(name, sizeof name, "mask_%04d.npy", i);
    std::vector<float> m(size_t(W * H), 0.0f);
    for (int y = 3; y < 9; ++y)
      for (int x = 5; x < 11; ++x) m[size_t(y * W + x)] = 1.0f;
    write_npy((ps / "masks" / name).string(), NpyArray::from(m, {H, W}));
  }
  Npz cams;
  cams.set("intrinsic", NpyArray::from(std::vector<double>{20, 0, 8, 0, 20, 6, 0, 0, 1}, {3, 3}));
  cams.set("extrinsic", NpyArray::from(std::vector<double>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1}, {4, 4}));
  cams.set("height", NpyArray::from(std::vector<int64_t>{H}, {}));
  cams.set("width", NpyArray::from(std::vector<int64_t>{W}, {}));
  cams.write((ps / "cameras.npz").string());
  // SMPL poses: train frames 0, 2 and test frame 4.
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 0.25);
  std::vector<std::vector<double>> transl;
  for (const auto& [split, n] : {std::pair<const char*, int>{"train", 2}, {"test", 1}}) {
    std::vector<double> orient, body, t;
    for (int r = 0; r < n; ++r) {
      for (int k = 0; k < 3; ++k) orient.push_back(k == 1 ? 3 * g(rng) : g(rng));
      for (int k = 0; k < 69; ++k) body.push_back(k < 63 ? g(rng) : 0.0);  // SMPL hands at rest
      for (int k = 0; k < 3; ++k) t.push_back(g(rng));
      transl.push_back({t[t.size() - 3], t[t.size() - 2], t[t.size() - 1]});
    }
    Npz z;
    z.set("betas", NpyArray::from(std::vector<float>{0.2f, 0, 0, 0, 0, 0, 0, 0, 0, 0}, {1, 10}));
    z.set("global_orient", NpyArray::from(orient, {n, 3}));
    z.set("body_pose", NpyArray::from(body, {n, 69}));
    z.set("transl", NpyArray::from(t, {n, 3}));
    z.write((ps / "poses" / (std::string("anim_nerf_") + split + ".npz")).string());
  }

  const std::string base = "'" + kHaha.string() + "' convert --from peoplesnapshot --in '" + ps.string() +
                           "' --train-frames 0:4:2 --test-frames 4:6:2 --out '" + (dir / "out").string() + "'";
  const std::string redirect = " > '" + (dir / "o.txt").string() + "' 2> '" + (dir / "e.txt").string() + "'";
  // No SMPL model: exit 1, one line, naming it; nothing written.
  EXPECT_EQ(WEXITSTATUS(std::system((base + " --model '" + (dir / "smplx.npz").string() + "'" + redirect).c_str())), 1);
  const std::string e = slurp(dir / "e.txt");
  EXPECT_EQ(e.rfind("haha: error: --smpl-model: ", 0), 0u) << e;
  EXPECT_NE(e.find("SMPL model"), std::string::npos) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  EXPECT_FALSE(fs::exists(dir / "out"));

  ASSERT_EQ(WEXITSTATUS(std::system((base + " --model '" + (dir / "smplx.npz").string() + "' --smpl-model '" +
                                     (dir / "smpl.npz").string() + "' --smpl-correspondence '" + (dir / "corr.npz").string() +
                                     "'" + redirect)
                                        .c_str())),
            0)
      << slurp(dir / "e.txt");
  std::printf("%s", slurp(dir / "o.txt").c_str());
  // Per-frame residual lines, each under 5 mm.
  std::istringstream out(slurp(dir / "o.txt"));
  int lines = 0;
  for (std::string line; std::getline(out, line);) {
    double jm = 0, vm = 0;
    int f = 0;
    if (std::sscanf(line.c_str(), "frame %d: residual joints %lf mm, vertices %lf mm", &f, &jm, &vm) == 3) {
      ++lines;
      EXPECT_LT(jm, 5.0) << line;
      EXPECT_LT(vm, 5.0) << line;
    }
  }
  EXPECT_EQ(lines, 3) << slurp(dir / "o.txt");
  // The known template shift is in the converted transl.
  const Dataset ds = read_dataset((dir / "out").string(), LoadPixels::headers);
  ASSERT_EQ(ds.frames.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += std::pow(ds.frames[i].params.transl[size_t(k)] - (transl[i][size_t(k)] + so.shift[size_t(k)]), 2);
    EXPECT_LT(std::sqrt(d2), 0.005) << "frame " << i;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
