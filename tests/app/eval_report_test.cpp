// The evaluation report: requirement checks, JSON / Markdown content, contact sheet.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "app/eval_report.h"
#include "support/data_test_util.h"
#include "io/image.h"

namespace haha {
namespace {

EvalReport make_report(int full_n, int filt_n, double mesh_psnr, double full_psnr, double filt_psnr) {
  EvalReport r;
  r.run_dir = "run";
  r.data_dir = "ds";
  r.tto_steps = 5;
  r.stage_seconds = {10, 2, 5};
  r.frame_names = {"a.png", "b.png"};
  auto v = [](const char* name, bool mesh, bool gs, int n, double psnr) {
    VariantEval e;
    e.name = name;
    e.mesh = mesh;
    e.gaussians = gs;
    e.num_gaussians = n;
    e.psnr = psnr;
    e.ssim = 0.9;
    for (int k = 0; k < 2; ++k) {
      FrameEval f;
      f.psnr = psnr + (k ? 0.5 : -0.5);
      f.image.assign(8 * 8 * 3, 0.5f);
      f.ground_truth.assign(8 * 8 * 3, 0.4f);
      f.gaussian_layer.assign(8 * 8 * 3, 0.1f);
      f.mesh_layer.assign(8 * 8 * 3, 0.3f);
      e.frames.push_back(f);
    }
    return e;
  };
  r.variants = {v("mesh only", true, false, 0, mesh_psnr), v("full Gaussians", false, true, full_n, full_psnr),
                v("naive merge", true, true, full_n, full_psnr - 0.3), v("HAHA filtered", true, true, filt_n, filt_psnr)};
  for (size_t i = 0; i < r.variants.size(); ++i) r.variants[i].paper_row = i;
  r.regions_full = {10, 20, 30, 5, 40, 7};
  r.regions_filtered = {8, 2, 3, 0, 30, 1};
  return r;
}

TEST(EvalReport, ChecksFollowTheRequirements) {
  EvalChecks c = eval_checks(make_report(1000, 500, 25.0, 28.0, 27.5));
  EXPECT_TRUE(c.count_ok);         // exactly half
  EXPECT_TRUE(c.psnr_vs_full_ok);  // exactly -0.5 dB
  EXPECT_TRUE(c.psnr_vs_mesh_ok);
  EXPECT_DOUBLE_EQ(c.count_ratio, 0.5);
  c = eval_checks(make_report(1000, 501, 27.0, 28.0, 27.4));
  EXPECT_FALSE(c.count_ok);
  EXPECT_FALSE(c.psnr_vs_full_ok);
  EXPECT_FALSE(c.psnr_vs_mesh_ok);
  EXPECT_NEAR(c.psnr_minus_mesh, 0.4, 1e-12);
  EXPECT_DOUBLE_EQ(variant_train_seconds(make_report(1, 1, 1, 1, 1).stage_seconds, 0), 2.0);   // mesh: stage 2
  EXPECT_DOUBLE_EQ(variant_train_seconds(make_report(1, 1, 1, 1, 1).stage_seconds, 1), 10.0);  // full: stage 1
  EXPECT_DOUBLE_EQ(variant_train_seconds(make_report(1, 1, 1, 1, 1).stage_seconds, 3), 17.0);  // HAHA: all
}

TEST(EvalReport, JsonAndMarkdownCarryTheTable) {
  const EvalReport r = make_report(1000, 300, 25.0, 28.0, 27.8);
  const auto j = nlohmann::json::parse(eval_report_json(r));
  ASSERT_EQ(j["variants"].size(), 4u);
  EXPECT_EQ(j["variants"][3]["name"], "HAHA filtered");
  EXPECT_EQ(j["variants"][3]["gaussians"], 300);
  EXPECT_EQ(j["variants"][1]["frames"].size(), 2u);
  EXPECT_TRUE(j["variants"][0]["lpips"].is_null());  // no LPIPS weights: not a number
  EXPECT_EQ(j["checks"]["filtered_at_most_half"], true);
  EXPECT_EQ(j["regions"][4]["region"], "legs");
  EXPECT_EQ(j["regions"][4]["filtered"], 30);
  const std::string md = eval_report_markdown(r);
  EXPECT_NE(md.find("| HAHA filtered | 300 |"), std::string::npos);
  EXPECT_NE(md.find("unavailable"), std::string::npos);
  EXPECT_NE(md.find("PASS (30.0%)"), std::string::npos);
  EXPECT_NE(md.find("| legs | 40 | 30 | 75% |"), std::string::npos);
}

TEST(EvalReport, SomeRowsOnlyHaveNoChecksAndTheirOwnTrainingTime) {
  EvalReport r = make_report(1000, 300, 25.0, 28.0, 27.8);
  r.variants.erase(r.variants.begin(), r.variants.begin() + 3);  // `--variants haha`
  EXPECT_FALSE(eval_checks(r).complete);
  EXPECT_TRUE(eval_checks(make_report(1000, 300, 25.0, 28.0, 27.8)).complete);
  const auto j = nlohmann::json::parse(eval_report_json(r));
  ASSERT_EQ(j["variants"].size(), 1u);
  EXPECT_EQ(j["variants"][0]["key"], "haha");
  EXPECT_DOUBLE_EQ(j["variants"][0]["train_seconds"].get<double>(), 17.0);  // all three stages, not row 0's
  EXPECT_FALSE(j.contains("checks"));
  const std::string md = eval_report_markdown(r);
  EXPECT_NE(md.find("| HAHA filtered | 300 |"), std::string::npos);
  EXPECT_EQ(md.find("Requirements"), std::string::npos);
}

TEST(EvalReport, APartsPsnrIsReportedOnlyWhenAsked) {
  EvalReport r = make_report(1000, 300, 25.0, 28.0, 27.8);
  EXPECT_FALSE(nlohmann::json::parse(eval_report_json(r))["variants"][3].contains("psnr_part"));
  EXPECT_EQ(eval_report_markdown(r).find("garment"), std::string::npos);
  r.part = "garment";
  r.variants[3].psnr_part = 21.25;
  r.variants[3].frames[1].psnr_part = 22.5;
  r.variants[0].psnr_part = std::nan("");  // no garment pixels in any frame
  const auto j = nlohmann::json::parse(eval_report_json(r));
  EXPECT_EQ(j["part"], "garment");
  EXPECT_DOUBLE_EQ(j["variants"][3]["psnr_part"].get<double>(), 21.25);
  EXPECT_DOUBLE_EQ(j["variants"][3]["frames"][1]["psnr_part"].get<double>(), 22.5);
  EXPECT_TRUE(j["variants"][0]["psnr_part"].is_null());
  EXPECT_NE(eval_report_markdown(r).find("PSNR over the garment's pixels"), std::string::npos);
  EXPECT_NE(eval_report_markdown(r).find("HAHA filtered 21.25 dB."), std::string::npos);
  r.variants[3].transmittance_part = 0.005;
  EXPECT_NE(eval_report_markdown(r).find("HAHA filtered 0.50%."), std::string::npos);
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(eval_report_json(r))["variants"][3]["transmittance_part"].get<double>(), 0.005);
}

TEST(EvalReport, ThePersonsPsnrIsAColumnOfEveryRow) {
  EvalReport r = make_report(1000, 300, 25.0, 28.0, 27.8);
  r.variants[0].psnr_person = 19.25;
  r.variants[0].frames[1].psnr_person = 18.5;
  r.variants[2].psnr_person = std::nan("");  // no frame had person pixels
  const auto j = nlohmann::json::parse(eval_report_json(r));
  EXPECT_DOUBLE_EQ(j["variants"][0]["psnr_person"].get<double>(), 19.25);
  EXPECT_DOUBLE_EQ(j["variants"][0]["frames"][1]["psnr_person"].get<double>(), 18.5);
  EXPECT_TRUE(j["variants"][2]["psnr_person"].is_null());
  const std::string md = eval_report_markdown(r);
  EXPECT_NE(md.find("| PSNR | person PSNR | outline PSNR |"), std::string::npos) << md;
  EXPECT_NE(md.find("| mesh only | 0 | 0.000 | 25.00 | 19.25 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| naive merge | 1000 | 0.000 | 27.70 | n/a |"), std::string::npos) << md;
}

class EvalReportFiles : public testutil::TempDirTest {};

TEST_F(EvalReportFiles, WritesReportAndSheet) {
  EvalReport r = make_report(1000, 300, 25.0, 28.0, 27.8);
  r.run_dir = dir_.string();
  write_eval_report(r);
  EXPECT_TRUE(std::filesystem::exists(path("report.json")));
  EXPECT_TRUE(std::filesystem::exists(path("report.md")));
  write_eval_contact_sheet(path("sheet.png"), r, 8, 8);
  const Image im = read_image(path("sheet.png"));
  EXPECT_GT(im.width, 6 * 8);  // six columns
  EXPECT_GT(im.height, 2 * 8);  // two rows
  EXPECT_TRUE(leftovers().empty());
  EvalReport empty = r;
  for (VariantEval& v : empty.variants)
    for (FrameEval& f : v.frames) f.image.clear();
  testutil::expect_error([&] { write_eval_contact_sheet(path("none.png"), empty, 8, 8); }, {"no frame images"});
}

}  // namespace
}  // namespace haha
