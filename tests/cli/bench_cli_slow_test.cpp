// End to end through the `haha` executable on a tiny synthetic run: synth -> train ->
// bench, then checks of bench.json (fields, finite numbers, monotonic sanity), the plots
// (valid PNGs with data drawn) and bench.md; plus `haha motion`. Skips when the executable
// has not been built next to this test (build/cli/haha).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "bench/bench_sweeps.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "app/train_run.h"
#include "core/error.h"
#include "data/dataset.h"
#include "format/avatar_npz.h"
#include "io/image.h"
#include "io/motion.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

using haha::test::kHaha;
using haha::test::slurp;

int run(const std::string& args, const fs::path& log) {
  const std::string cmd = "'" + kHaha.string() + "' " + args + " > '" + log.string() + "' 2>&1";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

// Every number in the document is finite (the writer turns NaN / Inf into null, so a null
// where a number belongs is the failure); returns the count of numbers seen.
int check_finite(const json& j, const std::string& path) {
  int n = 0;
  if (j.is_number()) {
    EXPECT_TRUE(std::isfinite(j.get<double>())) << path;
    return 1;
  }
  if (j.is_null()) {
    ADD_FAILURE() << path << " is null (a non-finite measurement)";
    return 0;
  }
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) n += check_finite(it.value(), path + "." + it.key());
  if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) n += check_finite(j[i], path + "[" + std::to_string(i) + "]");
  return n;
}

// A readable plot: a PNG of a sensible size with ink (axes, text) and coloured series.
void check_plot(const fs::path& p) {
  SCOPED_TRACE(p.string());
  ASSERT_TRUE(fs::exists(p));
  {
    std::ifstream f(p, std::ios::binary);
    char sig[8] = {};
    f.read(sig, 8);
    EXPECT_EQ(std::string(sig, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  }
  const Image img = read_image(p.string());
  EXPECT_GE(img.width, 640);
  EXPECT_GE(img.height, 400);
  ASSERT_GE(img.channels, 3);
  size_t ink = 0, coloured = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const float r = img.at(x, y, 0), g = img.at(x, y, 1), b = img.at(x, y, 2);
      if (std::min({r, g, b}) < 0.5f) ++ink;
      if (std::max({r, g, b}) - std::min({r, g, b}) > 0.3f) ++coloured;
    }
  const double npx = double(img.width) * img.height;
  EXPECT_GT(double(ink) / npx, 0.005) << "almost blank";
  EXPECT_LT(double(ink) / npx, 0.6) << "mostly dark: not a plot";
  EXPECT_GT(coloured, 150u) << "no coloured series drawn";
}

TEST(PipelineBench, TinyRunBenchReport) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-bench-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "log.txt";
  const std::string d = dir.string();

  ASSERT_EQ(run("synth --out '" + d + "/data' --size 64 --frames 8 --test-frames 3 --body-resolution low", log), 0)
      << slurp(log);
  ASSERT_EQ(run("train --data '" + d + "/data' --out '" + d +
                    "/run' --preset tiny resolution=64 s1.steps=60 s2.steps=30 s3.steps=40 s1.densify.from=10 "
                    "s1.densify.until=50 s1.densify.every=20 s3.prune_every=20 s2.texture_size=64 log_every=1000",
                log),
            0)
      << slurp(log);
  const RunInfo info = read_run_info(RunDir(d + "/run"));
  char w0[64];
  std::snprintf(w0, sizeof w0, "%.17g", info.config.s3.w.opacity);  // exact round trip
  ASSERT_GT(info.config.s3.w.opacity, 0.0);
  ASSERT_LT(info.config.s3.w.opacity, 0.3);
  ASSERT_EQ(run("bench --run '" + d + "/run' --out '" + d +
                    "/bench' --opacity-weights 0.3,0," + std::string(w0) + " --prune-thresholds 0.9,0,0.2,0.5 --resolutions 64,512 "
                    "--count-resolution 128 --repeats 2",
                log),
            0)
      << slurp(log);
  const std::string out = slurp(log);
  EXPECT_NE(out.find("[bench"), std::string::npos) << "no progress lines";

  const json j = json::parse(slurp(dir / "bench" / "bench.json"));
  EXPECT_EQ(j.at("format"), "haha-bench");
  EXPECT_FALSE(j.at("machine").at("cpu_model").get<std::string>().empty());
  EXPECT_GE(j.at("machine").at("logical_cpus").get<int>(), 1);
  for (const char* k : {"training", "filtering", "packing", "render", "seconds", "plots", "eval"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_GT(check_finite(j.at("training"), "training") + check_finite(j.at("filtering"), "filtering") +
                check_finite(j.at("packing"), "packing") + check_finite(j.at("render"), "render") +
                check_finite(j.at("seconds"), "seconds"),
            100);

  // Training: the stage table.
  const json& rows = j.at("training").at("rows");
  ASSERT_EQ(rows.size(), 4u);
  std::map<std::string, json> row;
  for (const json& r : rows) row[r.at("name")] = r;
  EXPECT_EQ(row.at("mesh only").at("gaussians"), 0);
  EXPECT_LE(row.at("HAHA filtered").at("gaussians").get<int>(), row.at("full Gaussians").at("gaussians").get<int>());
  EXPECT_GT(row.at("HAHA filtered").at("train_seconds").get<double>(), row.at("mesh only").at("train_seconds").get<double>());
  for (const json& r : rows) {
    EXPECT_GT(r.at("psnr").get<double>(), 8.0) << r;
    EXPECT_LT(r.at("psnr").get<double>(), 80.0) << r;
    EXPECT_LE(r.at("ssim").get<double>(), 1.0) << r;
  }

  // Filtering: a higher pruning threshold never keeps more Gaussians; a stronger opacity
  // regulariser does not keep more either (beyond the pruning noise of a short stage 3).
  std::vector<std::pair<double, int>> prune, weight;
  for (const json& p : j.at("filtering")) {
    (p.at("method") == "prune threshold" ? prune : weight).emplace_back(p.at("strength"), p.at("gaussians"));
    EXPECT_EQ(p.at("storage_bytes").get<int64_t>() > row.at("mesh only").at("storage_bytes").get<int64_t>(),
              p.at("gaussians").get<int>() > 0);
  }
  ASSERT_EQ(prune.size(), 4u);
  ASSERT_EQ(weight.size(), 3u);
  std::sort(prune.begin(), prune.end());
  for (size_t i = 1; i < prune.size(); ++i) EXPECT_LE(prune[i].second, prune[i - 1].second) << prune[i].first;
  EXPECT_EQ(prune[0].second, row.at("HAHA filtered").at("gaussians").get<int>());  // threshold 0 keeps all
  std::sort(weight.begin(), weight.end());
  for (size_t i = 1; i < weight.size(); ++i)
    EXPECT_LE(weight[i].second, weight[i - 1].second + weight[i - 1].second / 20) << "weight " << weight[i].first;
  EXPECT_EQ(weight[1].second, row.at("HAHA filtered").at("gaussians").get<int>());  // the run's own weight

  // Training is deterministic: stage 3 re-run from checkpoint_stage2.npz with the run's own
  // weight reproduces the trained avatar (what lets the bench read that point off the run).
  {
    const Avatar trained = load_run_avatar(RunDir(d + "/run"));
    Dataset ds = read_dataset(info.data_path, LoadPixels::headers);
    RetrainSetup setup;
    setup.config = info.config;
    setup.input.body = &trained.body;
    setup.input.premultiplied = dataset_premultiplied(ds, info.config.premultiplied);
    setup.input.frames = dataset_frames(ds, Split::train, info.config.resolution);
    setup.checkpoint_path = d + "/run/checkpoint_stage2.npz";
    setup.stage2 = read_checkpoint(setup.checkpoint_path);
    BenchEval ev;
    ev.frames = dataset_frames(ds, Split::test, info.config.resolution);
    ev.options.tto_steps = 0;
    ev.options.premultiplied = setup.input.premultiplied;
    const std::vector<FilterPoint> again = sweep_stage3(setup, Stage3Knob::opacity_weight, {info.config.s3.w.opacity}, ev, nullptr);
    ASSERT_EQ(again.size(), 1u);
    EXPECT_EQ(again[0].q.gaussians, trained.gaussians.size());
    EXPECT_NEAR(again[0].q.psnr, row.at("HAHA filtered").at("psnr").get<double>(), 1e-6);
    // The image-cost knob: a cost no Gaussian reaches deletes them all at the first prune.
    const std::vector<FilterPoint> costs = sweep_stage3(setup, Stage3Knob::image_cost, {1e12}, ev, nullptr);
    ASSERT_EQ(costs.size(), 1u);
    EXPECT_EQ(costs[0].method, "image cost");
    EXPECT_EQ(costs[0].strength, 1e12);
    EXPECT_EQ(costs[0].q.gaussians, 0);
    // A checkpoint that is not at the start of stage 3 is refused, naming the file.
    setup.stage2 = read_checkpoint(d + "/run/checkpoint_stage1.npz");
    try {
      sweep_stage3(setup, Stage3Knob::opacity_weight, {0.0}, ev, nullptr);
      ADD_FAILURE() << "a stage-1 checkpoint was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(setup.checkpoint_path + ": ", 0), 0u) << e.what();
    }
  }

  // Packing: lossless is (nearly) exact; more bits -> not more error (1 dB of noise allowed)
  // and not fewer bytes; a smaller texture -> fewer texture bytes.
  std::vector<std::tuple<int, double, int64_t>> bits;
  std::map<int, int64_t> tex_bytes;
  std::string default_codec;
  for (const json& p : j.at("packing")) {
    if (p.at("lossless").get<bool>()) {
      EXPECT_TRUE(p.at("identical").get<bool>() || p.at("psnr_vs_original").get<double>() > 50.0) << p;
    }
    if (p.at("group") == "gaussian bits")
      bits.emplace_back(p.at("gaussian_bits"), p.at("psnr_vs_original"), p.at("gaussian_bytes"));
    if (p.at("group") == "texture" && p.at("name").get<std::string>().find("(default)") != std::string::npos)
      default_codec = p.at("texture_codec").get<std::string>() + "/" + std::to_string(p.at("texture_quality").get<int>());
    EXPECT_GT(p.at("decode_ms").get<double>(), 0.0);
    EXPECT_GT(p.at("bytes").get<int64_t>(), 0);
  }
  ASSERT_GE(bits.size(), 4u);
  std::sort(bits.begin(), bits.end());
  for (size_t i = 1; i < bits.size(); ++i) {
    EXPECT_GE(std::get<1>(bits[i]), std::get<1>(bits[i - 1]) - 1.0) << std::get<0>(bits[i]) << " bits";
    EXPECT_GE(std::get<2>(bits[i]), std::get<2>(bits[i - 1])) << std::get<0>(bits[i]) << " bits";
  }
  EXPECT_GT(std::get<1>(bits.back()), std::get<1>(bits.front()) + 3.0) << "16 bits no better than 4";
  // The size series is in the format's default codec; its trained-size point is "(default)".
  ASSERT_FALSE(default_codec.empty()) << "no setting equals the format's defaults";
  for (const json& p : j.at("packing"))
    if (p.at("group") == "texture" &&
        p.at("texture_codec").get<std::string>() + "/" + std::to_string(p.at("texture_quality").get<int>()) == default_codec)
      tex_bytes[p.at("texture_size")] = p.at("texture_bytes");
  ASSERT_GE(tex_bytes.size(), 2u);
  // Key 0 is the trained size (64 here), the others are smaller.
  for (const auto& [size, b] : tex_bytes) {
    if (size != 0) {
      EXPECT_LT(b, tex_bytes.at(0)) << size;
    }
  }

  // Render: a 512 px frame takes longer than a 64 px one (64 times the pixels) for every
  // single-thread series (fastest runs: other programs share this machine's cores, and
  // multi-thread timings on a loaded machine measure the scheduler).
  std::map<std::string, std::map<int, double>> series;
  for (const json& t : j.at("render")) {
    if (t.at("sweep") != "resolution" || t.at("threads") != 1) continue;
    const std::string key = t.at("device").get<std::string>() + "/" + std::to_string(t.at("threads").get<int>()) + "/" +
                            std::to_string(t.at("gaussians").get<int>()) + "/" + (t.at("mesh").get<bool>() ? "m" : "");
    series[key][t.at("resolution")] = t.at("ms_min");
  }
  ASSERT_FALSE(series.empty());
  for (const auto& [key, s] : series) EXPECT_GT(s.at(512), s.at(64)) << key;

  // Plots and the Markdown report.
  const std::string md = slurp(dir / "bench" / "bench.md");
  ASSERT_GE(j.at("plots").size(), 6u);
  for (const json& p : j.at("plots")) {
    check_plot(dir / "bench" / p.get<std::string>());
    EXPECT_NE(md.find("](" + p.get<std::string>() + ")"), std::string::npos) << p;
  }
  fs::remove_all(dir);
}

TEST(PipelineBench, MotionCommandWritesALoopReadByRender) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-motion-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* kind : {"wave", "walk", "turn", "kick"}) {
    const fs::path m = dir / (std::string(kind) + ".npz");
    ASSERT_EQ(run(std::string("motion --kind ") + kind + " --frames 12 --fps 25 --out '" + m.string() + "'", dir / "log"), 0)
        << slurp(dir / "log");
    const Motion mo = read_motion(m.string());
    ASSERT_EQ(mo.frames.size(), 12u) << kind;
    EXPECT_DOUBLE_EQ(mo.fps, 25.0);
    double change = 0;
    for (size_t t = 1; t < mo.frames.size(); ++t)
      for (size_t k = 0; k < mo.frames[t].pose.size(); ++k) change += std::fabs(mo.frames[t].pose[k] - mo.frames[0].pose[k]);
    EXPECT_GT(change, 1.0) << kind << ": the motion does not move";
  }
  EXPECT_EQ(run("motion --kind moonwalk --out '" + (dir / "x.npz").string() + "'", dir / "log"), 1);
  EXPECT_NE(slurp(dir / "log").find("haha: error: --kind: unknown motion 'moonwalk'"), std::string::npos) << slurp(dir / "log");
  EXPECT_FALSE(fs::exists(dir / "x.npz"));
  EXPECT_EQ(run("bench --run '" + (dir / "missing").string() + "' --out '" + (dir / "b").string() + "'", dir / "log"), 1);
  EXPECT_NE(slurp(dir / "log").find("haha: error: " + (dir / "missing").string()), std::string::npos) << slurp(dir / "log");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
