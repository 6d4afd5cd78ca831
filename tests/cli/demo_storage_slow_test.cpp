// The demo avatar's storage figures, which README.md and docs/results.md ("Storage", format
// version 3) quote: the demo's own steps through the `haha` executable (haha synth, haha
// train --preset tiny, haha pack with and without --mesh-compression none), then the
// bytes per part and the PSNR of the unpacked file's renders against the trained avatar
// over the 10 test poses (bench/bench_sweeps.h, as `haha bench` measures them). Training
// is deterministic, so the figures are asserted exactly (PSNR to the printed 0.01 dB): a
// change that moves them must update the documents with them. Prints the table.
// Skips when the executable has not been built next to this test (build/cli/haha).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "app/run_dir.h"
#include "app/train_frames.h"
#include "bench/bench_sweeps.h"
#include "data/dataset.h"
#include "format/avatar_pack.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using test::kHaha;

struct DocumentedFile {
  const char* name;
  bool plain_mesh;
  size_t total, mesh, gaussians;
  double psnr_vs_trained;  // dB, as printed (two decimals)
};

// README.md "The file" and docs/results.md "Storage" (the rows with the texture's evidence
// prior and fill).
constexpr DocumentedFile kDocumented[] = {
    {"default (Draco mesh)", false, 159436, 64489, 47043, 49.05},
    {"--mesh-compression none", true, 671960, 576768, 47043, 49.09},
};
constexpr int kDemoGaussians = 6319;

TEST(DemoStorage, TheDocumentedFiguresOfTheDemoAvatar) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << kHaha << " is not built";
  const fs::path dir = fs::temp_directory_path() / ("haha_demo_storage_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto haha = [&](const std::string& args) {
    const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + (dir / "log.txt").string() + "' 2>&1";
    const int st = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << args << "\n" << test::slurp(dir / "log.txt");
  };
  // scripts/demo.sh's steps and settings.
  const std::string data = (dir / "data").string(), run = (dir / "run").string();
  haha("synth --out '" + data + "'");
  haha("train --data '" + data + "' --out '" + run + "' --preset tiny");
  haha("pack '" + run + "' --out '" + (dir / "default.glb").string() + "'");
  haha("pack '" + run + "' --out '" + (dir / "plain.glb").string() + "' --mesh-compression none");
  if (HasFatalFailure()) return;

  const RunDir rd(run);
  const RunInfo info = read_trained_run_info(rd, "demo storage test");
  const Avatar trained = load_run_avatar(rd);
  EXPECT_EQ(trained.gaussians.size(), kDemoGaussians);
  Dataset ds = read_dataset(data, LoadPixels::headers);
  BenchEval ev;
  ev.frames = dataset_frames(ds, Split::test, info.config.resolution);
  ASSERT_EQ(ev.frames.size(), 10u);
  ev.options.tto_steps = 0;

  std::vector<PackSetting> settings;
  for (const DocumentedFile& d : kDocumented) {
    PackSetting s;
    s.name = d.name;
    s.plain_mesh = d.plain_mesh;
    settings.push_back(s);
  }
  const std::vector<PackPoint> points = sweep_packing(trained, settings, ev, [](const std::string&) {});
  ASSERT_EQ(points.size(), settings.size());
  std::printf("%-26s %10s %10s %12s %10s %22s\n", "file", "bytes", "mesh B", "Gaussians B", "texture B", "PSNR vs trained avatar");
  for (size_t i = 0; i < points.size(); ++i) {
    const DocumentedFile& d = kDocumented[i];
    // The parts as `haha pack` and `haha info` count them (the mesh without the skeleton).
    PackOptions opt;
    opt.mesh_compression = d.plain_mesh ? MeshCompression::none : MeshCompression::draco;
    PackedSizes sz;
    const std::vector<uint8_t> bytes = pack_avatar(trained, opt, &sz);
    const double psnr = points[i].psnr_vs_original;
    std::printf("%-26s %10zu %10zu %12zu %10zu %19.2f dB\n", d.name, sz.total, sz.mesh, sz.gaussians, sz.texture, psnr);
    // What `haha pack` wrote, byte for byte; and the bench measured the same file.
    EXPECT_EQ(bytes, test::slurp_bytes(dir / (d.plain_mesh ? "plain.glb" : "default.glb"))) << d.name;
    EXPECT_EQ(points[i].bytes.total, sz.total) << d.name;
    EXPECT_EQ(sz.total, d.total) << d.name;
    EXPECT_EQ(sz.mesh, d.mesh) << d.name;
    EXPECT_EQ(sz.gaussians, d.gaussians) << d.name;
    EXPECT_NEAR(psnr, d.psnr_vs_trained, 0.005) << d.name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
