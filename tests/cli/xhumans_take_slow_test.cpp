// The X-Humans path end to end: `haha synth --xhumans` writes the synthetic subject as
// X-Humans takes (800 x 1200 colour PNGs, depth TIFFs with the far background, cameras.npz,
// one SMPL-X pickle per frame); `haha convert --from xhumans` must give back the native
// dataset (images >= 40 dB after the square crop, masks = the native masks at 0.5, fits
// exactly); then `train` -> `eval` on the converted take must give the native sample's
// stage table (same variants, filtering never adds Gaussians, PSNR close to the native run's).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "train/losses.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

class XHumansTake : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("haha-xhumans-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Runs `haha ARGS`; its stdout lands in dir_/NAME.out.
  void haha(const std::string& args, const std::string& name) {
    const std::string cmd = "OMP_WAIT_POLICY=passive '" + kHaha.string() + "' " + args + " > '" + (dir_ / (name + ".out")).string() +
                            "' 2> '" + (dir_ / (name + ".err")).string() + "'";
    ASSERT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 0) << name << ": " << slurp(dir_ / (name + ".err"));
  }
  std::string p(const std::string& rel) const { return "'" + (dir_ / rel).string() + "'"; }
  fs::path dir_;
};

TEST_F(XHumansTake, ConvertsBackToTheNativeDatasetAndTrainsLikeIt) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const std::string synth = " --frames 4 --test-frames 2 --body-resolution low --seed 3";
  haha("synth --out " + p("native800") + " --size 800 --supersample 1 --xhumans " + p("takes") + synth, "synth800");
  for (const char* f : {"takes/train/Take1/render/image/color_000001.png", "takes/train/Take1/render/depth/depth_000004.tiff",
                        "takes/train/Take1/render/cameras.npz", "takes/test/Take2/SMPLX/mesh-f00002_smplx.pkl"})
    EXPECT_TRUE(fs::exists(dir_ / f)) << f;
  haha("convert --from xhumans --in " + p("takes/train/Take1") + " --test " + p("takes/test/Take2") + " --out " + p("conv800"),
       "convert800");

  // Frames, masks and fits against the native dataset.
  const Dataset native = read_dataset((dir_ / "native800").string()), conv = read_dataset((dir_ / "conv800").string());
  ASSERT_EQ(conv.frames.size(), native.frames.size());
  EXPECT_EQ(conv.width, 800);
  EXPECT_EQ(conv.height, 800);
  for (size_t i = 0; i < conv.frames.size(); ++i) {
    const DatasetFrame &c = conv.frames[i], &n = native.frames[i];
    EXPECT_EQ(c.split, n.split);
    ASSERT_EQ(c.image.data.size(), n.image.data.size());
    const double db = psnr(c.image.data.data(), n.image.data.data(), conv.height, conv.width);
    std::printf("frame %zu: image %.1f dB\n", i, db);
    EXPECT_GE(db, 40.0) << i;
    size_t differ = 0, partial = 0;
    for (size_t k = 0; k < c.mask.data.size(); ++k) {
      EXPECT_EQ(c.mask.data[k], n.mask.data[k] >= 0.5f ? 1.0f : 0.0f) << "frame " << i << " pixel " << k;
      differ += c.mask.data[k] != n.mask.data[k];
      partial += n.mask.data[k] > 0.0f && n.mask.data[k] < 1.0f;
    }
    EXPECT_LE(differ, partial);  // only the native mask's anti-aliased edge
    EXPECT_EQ(c.params.pose, n.params.pose) << i;
    EXPECT_EQ(c.params.transl, n.params.transl) << i;
    for (size_t k = 0; k < 10; ++k) {
      EXPECT_EQ(c.params.betas.at(k), k < n.params.betas.size() ? n.params.betas[k] : 0.0f) << i;
      EXPECT_EQ(c.params.expression.at(k), k < n.params.expression.size() ? n.params.expression[k] : 0.0f) << i;
    }
    EXPECT_NEAR(c.camera.cx, n.camera.cx, 1e-3);
    EXPECT_NEAR(c.camera.cy, n.camera.cy, 1e-3);
    EXPECT_NEAR(c.camera.t.z, n.camera.t.z, 1e-5);
  }

  // Train and evaluate the converted take and the native sample at the same small size.
  const std::string train = " --preset tiny s1.steps=150 s2.steps=80 s3.steps=200 s3.prune_every=100";
  haha("convert --from xhumans --in " + p("takes/train/Take1") + " --test " + p("takes/test/Take2") + " --size 96 --out " +
           p("conv96"),
       "convert96");
  haha("synth --out " + p("native96") + " --size 96" + synth, "synth96");
  nlohmann::json table[2];
  const char* names[2] = {"conv96", "native96"};
  for (int k = 0; k < 2; ++k) {
    const std::string run = std::string("run_") + names[k];
    haha("train --data " + p(names[k]) + " --model " + p("native800/body_model.npz") + " --out " + p(run) + train,
         run + "_train");
    haha("eval --run " + p(run) + " --data " + p(names[k]) + " --tto-steps 0 --json", run + "_eval");
    table[k] = nlohmann::json::parse(slurp(dir_ / (run + "_eval.out")));
  }
  const auto& vc = table[0]["variants"];
  const auto& vn = table[1]["variants"];
  ASSERT_EQ(vc.size(), vn.size());
  int full = -1, filtered = -1;
  for (size_t v = 0; v < vc.size(); ++v) {
    const std::string name = vc[v]["name"];
    EXPECT_EQ(name, vn[v]["name"].get<std::string>());
    const double pc = vc[v]["psnr"], pn = vn[v]["psnr"];
    std::printf("%-28s converted %6d G %.2f dB | native %6d G %.2f dB\n", name.c_str(), vc[v]["gaussians"].get<int>(), pc,
                vn[v]["gaussians"].get<int>(), pn);
    EXPECT_GT(pc, 18.0) << name;
    EXPECT_NEAR(pc, pn, 2.0) << name;
    if (name == "full Gaussians") full = int(v);
    if (name.find("HAHA") != std::string::npos) filtered = int(v);
  }
  ASSERT_GE(full, 0);
  ASSERT_GE(filtered, 0);
  EXPECT_LE(vc[size_t(filtered)]["gaussians"].get<int>(), vc[size_t(full)]["gaussians"].get<int>());
}

}  // namespace
}  // namespace haha
