// The pieces of `haha bench` that need no trained run: Gaussian pruning and subsampling,
// camera scaling, the machine line, pack settings, and the report (JSON fields, plots).
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "core/error.h"
#include "bench/bench_report.h"
#include "bench/bench_sweeps.h"

namespace haha {
namespace {

Avatar random_avatar(int n, uint64_t seed) {
  std::mt19937 rng{uint32_t(seed)};
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Avatar a;
  a.gaussians.resize(n);
  BoundGaussians& g = a.gaussians;
  for (int i = 0; i < n; ++i) {
    g.face[size_t(i)] = i % 7;
    g.opacity[size_t(i)] = u(rng);
    for (int k = 0; k < 3; ++k) {
      g.offset[3 * size_t(i) + k] = u(rng) - 0.5f;
      g.scale[3 * size_t(i) + k] = 0.01f + u(rng);
      g.color[3 * size_t(i) + k] = u(rng);
    }
    for (int k = 0; k < 4; ++k) g.rotation[4 * size_t(i) + k] = u(rng);
  }
  a.texture.width = a.texture.height = 4;
  a.texture.rgb.assign(48, 0.5f);
  a.betas = {0.1f, 0.2f};
  a.face_scale_divisor = 0.05f;
  return a;
}

// Index in `a` of Gaussian j of `sub` (by exact equality of every value), -1 if none.
int find_row(const Avatar& a, const Avatar& sub, int j) {
  const BoundGaussians &g = a.gaussians, &s = sub.gaussians;
  for (int i = 0; i < g.size(); ++i) {
    bool same = g.face[size_t(i)] == s.face[size_t(j)] && g.opacity[size_t(i)] == s.opacity[size_t(j)];
    for (int k = 0; k < 3 && same; ++k)
      same = g.offset[3 * size_t(i) + k] == s.offset[3 * size_t(j) + k] &&
             g.scale[3 * size_t(i) + k] == s.scale[3 * size_t(j) + k] && g.color[3 * size_t(i) + k] == s.color[3 * size_t(j) + k];
    for (int k = 0; k < 4 && same; ++k) same = g.rotation[4 * size_t(i) + k] == s.rotation[4 * size_t(j) + k];
    if (same) return i;
  }
  return -1;
}

TEST(BenchPrune, KeepsExactlyTheGaussiansAtOrAboveTheThresholdInOrder) {
  const Avatar a = random_avatar(300, 1);
  int prev = a.gaussians.size() + 1;
  for (double t : {0.0, 0.1, 0.25, 0.5, 0.75, 0.99, 1.01}) {
    const Avatar p = prune_by_opacity(a, t);
    int expected = 0;
    for (float o : a.gaussians.opacity) expected += double(o) >= t;
    EXPECT_EQ(p.gaussians.size(), expected) << t;
    EXPECT_LE(p.gaussians.size(), prev) << "more Gaussians kept at a higher threshold " << t;
    prev = p.gaussians.size();
    int last = -1;
    for (int j = 0; j < p.gaussians.size(); ++j) {
      EXPECT_GE(double(p.gaussians.opacity[size_t(j)]), t);
      const int i = find_row(a, p, j);
      ASSERT_GE(i, 0) << "a kept Gaussian is not a copy of an original one";
      EXPECT_GT(i, last) << "order changed";
      last = i;
    }
    // Everything but the Gaussians is carried over.
    EXPECT_EQ(p.texture.rgb, a.texture.rgb);
    EXPECT_EQ(p.betas, a.betas);
    EXPECT_EQ(p.face_scale_divisor, a.face_scale_divisor);
  }
  EXPECT_EQ(prune_by_opacity(a, 0.0).gaussians.size(), a.gaussians.size());
  EXPECT_EQ(prune_by_opacity(a, 1.01).gaussians.size(), 0);
  // NaN opacity never passes a threshold.
  Avatar b = a;
  b.gaussians.opacity[0] = NAN;
  EXPECT_EQ(prune_by_opacity(b, 0.0).gaussians.size(), a.gaussians.size() - 1);
}

TEST(BenchSubsample, KeepsTheRequestedShareSpreadOverTheList) {
  const Avatar a = random_avatar(101, 2);
  EXPECT_EQ(subsample_gaussians(a, 1.0).gaussians.size(), 101);
  const Avatar h = subsample_gaussians(a, 0.5);
  EXPECT_EQ(h.gaussians.size(), 51);  // round(50.5)
  std::set<int> rows;
  for (int j = 0; j < h.gaussians.size(); ++j) {
    const int i = find_row(a, h, j);
    ASSERT_GE(i, 0);
    rows.insert(i);
  }
  EXPECT_EQ(rows.size(), 51u);               // no Gaussian twice
  EXPECT_LE(*rows.begin(), 1);               // from the start ...
  EXPECT_GE(*rows.rbegin(), 98);             // ... to the end of the list
  EXPECT_EQ(subsample_gaussians(a, 1e-6).gaussians.size(), 1);
  EXPECT_THROW(subsample_gaussians(a, 0.0), Error);
  EXPECT_THROW(subsample_gaussians(a, 1.5), Error);
  EXPECT_THROW(subsample_gaussians(a, NAN), Error);
}

TEST(BenchCamera, ScalingKeepsWhereAPointProjects) {
  Camera c;
  c.width = 128;
  c.height = 96;
  c.fx = 150;
  c.fy = 140;
  c.cx = 64.5f;
  c.cy = 47.0f;
  const Camera s = scaled_camera(c, 512);
  EXPECT_EQ(s.width, 512);
  EXPECT_EQ(s.height, 384);
  const Vec3f x(0.1f, -0.2f, 2.0f);
  const Vec2f p = c.project(x), q = s.project(x);
  // Pixel-edge convention: a point's pixel coordinates scale by the size ratio exactly.
  EXPECT_NEAR(q.x, 4.0f * p.x, 1e-3f);
  EXPECT_NEAR(q.y, 4.0f * p.y, 1e-3f);
  EXPECT_THROW(scaled_camera(c, 0), Error);
}

TEST(BenchMachine, NamesTheCpuAndCountsCores) {
  const MachineInfo m = machine_info();
  EXPECT_FALSE(m.cpu_model.empty());
  EXPECT_GE(m.logical_cpus, 1);
  EXPECT_GE(m.threads, 1);
  EXPECT_NE(m.line().find(m.cpu_model), std::string::npos);
  EXPECT_NE(m.line().find(std::to_string(m.logical_cpus) + " logical CPU"), std::string::npos);
}

TEST(BenchPackSettings, CoverTheReferenceBitsAndTextures) {
  const std::vector<PackSetting> s = default_pack_settings(256, "webp", 95);
  ASSERT_FALSE(s.empty());
  EXPECT_TRUE(s[0].lossless);
  std::vector<int> bits;
  std::set<int> sizes;
  std::set<std::string> codecs, names;
  for (const PackSetting& p : s) {
    EXPECT_TRUE(names.insert(p.name).second) << "duplicate name " << p.name;
    if (p.group == "gaussian bits") bits.push_back(p.gaussian_bits);
    if (p.group == "texture") sizes.insert(p.texture_size), codecs.insert(p.texture_codec);
  }
  ASSERT_GE(bits.size(), 4u);
  EXPECT_TRUE(std::is_sorted(bits.begin(), bits.end()));
  EXPECT_EQ(codecs, (std::set<std::string>{"png", "jpg", "webp"}));
  EXPECT_EQ(sizes, (std::set<int>{0, 128, 64, 32}));  // 0 = trained size
  // Exactly one setting is the format's default, and the smaller sizes use its codec.
  int defaults = 0;
  for (const PackSetting& p : s) {
    if (p.name.find("(default)") != std::string::npos) {
      ++defaults;
      EXPECT_EQ(p.texture_codec, "webp");
      EXPECT_EQ(p.texture_quality, 95);
      EXPECT_EQ(p.texture_size, 0);
    }
    if (p.group == "texture" && p.texture_size > 0) {
      EXPECT_EQ(p.texture_codec, "webp") << p.name;
    }
  }
  EXPECT_EQ(defaults, 1);
  for (const PackSetting& p : default_pack_settings(256, "png", 95)) {
    if (p.group == "texture" && p.texture_codec == "png") {
      EXPECT_EQ(p.name.find("(default)") != std::string::npos, p.texture_size == 0) << p.name;
    }
  }
}

BenchResult fake_result() {
  BenchResult r;
  r.machine = machine_info();
  r.run_dir = "/tmp/run";
  r.data_dir = "/tmp/data";
  r.preset = "tiny";
  r.date = bench_date();
  r.eval_frames = 3;
  r.eval_resolution = 64;
  r.stage_seconds = {10, 5, 7};
  r.stage_steps = {100, 50, 70};
  for (const char* n : {"mesh only", "full Gaussians", "naive merge", "HAHA filtered"}) {
    StageRow s;
    s.name = n;
    s.q.gaussians = s.name == "mesh only" ? 0 : s.name == "HAHA filtered" ? 500 : 2000;
    s.q.psnr = 25 + double(r.stages.size());
    s.q.ssim = 0.9;
    s.train_seconds = 5 + 3 * double(r.stages.size());
    r.stages.push_back(s);
  }
  for (double t : {0.0, 0.3, 0.6}) {
    FilterPoint p;
    p.method = "prune threshold";
    p.strength = t;
    p.q.gaussians = int(2000 * (1 - t));
    p.q.psnr = 28 - t;
    p.q.storage_bytes = p.q.gaussians * 60;
    p.q.render_ms = 3 + t;
    r.filtering.push_back(p);
  }
  FilterPoint w;
  w.method = "opacity weight";
  w.strength = 0.01;
  w.q.gaussians = 900;
  w.q.psnr = NAN;  // becomes null in JSON, left out of plots
  r.filtering.push_back(w);
  for (int b : {6, 10}) {
    PackPoint p;
    p.setting.name = "Gaussians " + std::to_string(b) + " bit";
    p.setting.group = "gaussian bits";
    p.setting.gaussian_bits = b;
    p.bytes.total = size_t(1000 * b);
    p.psnr_vs_original = 20 + 3 * b;
    r.packing.push_back(p);
  }
  for (int res : {64, 128})
    for (int g : {0, 500}) {
      RenderTiming t;
      t.sweep = "resolution";
      t.threads = 1;
      t.resolution = res;
      t.gaussians = g;
      t.ms_median = t.ms_min = res * 0.01 + g * 0.001;
      r.render.push_back(t);
    }
  for (int g : {0, 250, 500}) {
    RenderTiming t;
    t.sweep = "gaussians";
    t.threads = 1;
    t.resolution = 128;
    t.gaussians = g;
    t.ms_median = t.ms_min = 1 + g * 0.001;
    r.render.push_back(t);
  }
  r.seconds["training"] = 1.5;
  return r;
}

TEST(BenchReport, JsonHasEverySectionAndNoNonFiniteNumbers) {
  const BenchResult r = fake_result();
  const nlohmann::json j = nlohmann::json::parse(bench_json(r, {"plots/a.png"}));
  EXPECT_EQ(j.at("format"), "haha-bench");
  EXPECT_EQ(j.at("machine").at("cpu_model"), r.machine.cpu_model);
  EXPECT_EQ(j.at("training").at("rows").size(), 4u);
  EXPECT_EQ(j.at("filtering").size(), 4u);
  EXPECT_TRUE(j.at("filtering")[3].at("psnr").is_null());  // the NaN
  EXPECT_EQ(j.at("packing").size(), 2u);
  EXPECT_EQ(j.at("render").size(), 7u);
  EXPECT_EQ(j.at("render")[0].at("sweep"), "resolution");
  EXPECT_EQ(j.at("plots")[0], "plots/a.png");
  for (const char* k : {"psnr", "ssim", "render_ms", "train_seconds", "gaussians", "storage_bytes"})
    EXPECT_TRUE(j.at("training").at("rows")[0].contains(k)) << k;
}

TEST(BenchReport, PlotsHaveLabelledAxesAndLegends) {
  const BenchResult r = fake_result();
  const auto plots = bench_plots(r);
  std::set<std::string> names;
  for (const auto& [name, spec] : plots) {
    names.insert(name);
    EXPECT_FALSE(spec.title.empty()) << name;
    EXPECT_NE(spec.subtitle.find(r.machine.cpu_model), std::string::npos) << name << ": machine not stated";
    if (spec.xcategories.empty()) {
      EXPECT_NE(spec.xlabel.find('('), std::string::npos) << name << ": x axis without a unit";
    }
    EXPECT_FALSE(spec.xlabel.empty()) << name;
    EXPECT_NE(spec.ylabel.find('('), std::string::npos) << name << ": y axis without a unit";
    ASSERT_FALSE(spec.series.empty()) << name;
    for (const PlotSeries& s : spec.series) EXPECT_FALSE(s.label.empty()) << name;
    EXPECT_NO_THROW(gnuplot_script(spec, "x.png")) << name;
  }
  for (const char* n : {"filter_budget.png", "filter_budget_ssim.png", "pack_size_error.png", "pack_time.png",
                        "render_resolution.png", "render_gaussians.png", "training_quality.png"})
    EXPECT_TRUE(names.count(n)) << n;
  const std::string md = bench_markdown(r, {"plots/filter_budget.png"});
  EXPECT_NE(md.find("![Gaussian budget against error](plots/filter_budget.png)"), std::string::npos);
  EXPECT_NE(md.find(r.machine.cpu_model), std::string::npos);
}

}  // namespace
}  // namespace haha
