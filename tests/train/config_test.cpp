// Training config: presets, key=value overrides, errors, round trip through text.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "train/config.h"

namespace haha {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(TrainConfig, PaperPresetIsThePublishedSchedule) {
  const TrainConfig c = make_preset("paper");
  EXPECT_EQ(c.s1.steps, 3000);
  EXPECT_EQ(c.s2.steps, 2500);
  EXPECT_EQ(c.s3.steps, 5000);
  EXPECT_EQ(c.batch, 4);
  EXPECT_EQ(c.resolution, 544);
  EXPECT_DOUBLE_EQ(c.s1.lr_offset_init, 1.6e-4);
  EXPECT_DOUBLE_EQ(c.s1.lr_offset_final, 1.6e-6);
  EXPECT_DOUBLE_EQ(c.s1.lr_rotation, 5e-3);
  EXPECT_DOUBLE_EQ(c.s1.lr_scale, 5e-3);
  EXPECT_DOUBLE_EQ(c.s1.lr_color, 5e-3);
  EXPECT_DOUBLE_EQ(c.s1.lr_pose, 2e-4);
  EXPECT_DOUBLE_EQ(c.s1.lr_pose_fine, 2e-5);
  EXPECT_DOUBLE_EQ(c.s2.lr_texture, 0.01);
  EXPECT_DOUBLE_EQ(c.s3.lr_opacity, 0.05);
  EXPECT_DOUBLE_EQ(c.s3.lr_color, 5e-3);
  EXPECT_DOUBLE_EQ(c.s1.w.ssim, 0.1);
  EXPECT_DOUBLE_EQ(c.s1.w.sobel, 1.0);
  EXPECT_DOUBLE_EQ(c.s1.w.knn, 0.01);
  EXPECT_DOUBLE_EQ(c.s1.w.lpips, 0.01);
  EXPECT_DOUBLE_EQ(c.s2.w.tv, 0.01);
  EXPECT_DOUBLE_EQ(c.s3.w.dice, 0.1);
  EXPECT_DOUBLE_EQ(c.s3.prune_threshold, 0.1);
  EXPECT_EQ(c.s1.densify_every, 201);
  EXPECT_EQ(c.s1.knn_k, 3);
  EXPECT_NO_THROW(validate_config(c));
}

TEST(TrainConfig, TinyPresetIsSmallAndValid) {
  const TrainConfig c = make_preset("tiny");
  EXPECT_EQ(c.preset, "tiny");
  EXPECT_LE(c.resolution, 128);
  EXPECT_EQ(c.batch, 1);
  EXPECT_LT(c.total_steps(), make_preset("paper").total_steps() / 4);
  EXPECT_NO_THROW(validate_config(c));
  EXPECT_NE(error_of([] { make_preset("huge"); }).find("--preset: unknown preset 'huge'"), std::string::npos);
}

TEST(TrainConfig, OverridesSetEveryKind) {
  TrainConfig c = make_preset("tiny");
  apply_overrides(c, {"s1.steps=7", "seed=18446744073709551615", "s3.lr.opacity=0.25", "use_dice=false",
                      "premultiplied=true", "s3.opacity_mode=mean_abs", "random_background=on"});
  EXPECT_EQ(c.s1.steps, 7);
  EXPECT_EQ(c.seed, 18446744073709551615ull);
  EXPECT_DOUBLE_EQ(c.s3.lr_opacity, 0.25);
  EXPECT_FALSE(c.use_dice);
  EXPECT_EQ(c.premultiplied, "true");
  EXPECT_EQ(c.s3.opacity_mode, OpacityRegMode::MeanAbs);
  EXPECT_TRUE(c.random_background);
}

TEST(TrainConfig, BadOverridesNameTheKey) {
  TrainConfig c;
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"s1.stepz=3"}); }),
            "override: s1.stepz: unknown key (did you mean 's1.steps'?)");
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"s1.steps=3.5"}); }),
            "override: s1.steps: expected an integer, got '3.5'");
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"s3.lr.opacity=nan"}); }),
            "override: s3.lr.opacity: expected a finite number, got 'nan'");
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"use_dice=maybe"}); }),
            "override: use_dice: expected true or false, got 'maybe'");
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"nonsense"}); }), "override: 'nonsense': expected key=value");
  EXPECT_EQ(error_of([&] { apply_overrides(c, {"zzzzzzzzzzzzzz=1"}); }), "override: zzzzzzzzzzzzzz: unknown key");
}

TEST(TrainConfig, ValidationRejectsOutOfRangeValues) {
  auto check = [](const std::string& kv, const std::string& msg) {
    TrainConfig c = make_preset("tiny");
    apply_overrides(c, {kv});
    EXPECT_EQ(error_of([&] { validate_config(c); }), msg) << kv;
  };
  check("batch=0", "config: batch: must be >= 1");
  check("s1.steps=-1", "config: s1.steps: must be >= 0");
  check("s1.lr.color=-0.1", "config: s1.lr.color: must be finite and >= 0");
  check("s1.opacity=1", "config: s1.opacity: must be in (0, 1)");
  check("s1.knn.k=1", "config: s1.knn.k: must be >= 2 (the set holds the Gaussian itself)");
  check("premultiplied=sometimes", "config: premultiplied: must be auto, true or false");
  check("fits=roughly", "config: fits: must be auto, exact or estimated, got 'roughly'");
  check("s2.texture_size=2", "config: s2.texture_size: must be in [4, 8192]");
  // Checked before training, not when the finished avatar is saved.
  check("s3.depth_margin=1.5", "config: s3.depth_margin: must be <= 1 (metres; the avatar format's limit)");
  check("s3.depth_margin=-0.01", "config: s3.depth_margin: must be finite and >= 0");
}

TEST(TrainConfig, PairsRoundTripExactly) {
  TrainConfig a = make_preset("tiny");
  apply_overrides(a, {"s1.lr.offset_init=1.2345678901234567e-4", "seed=99", "use_sobel=false"});
  TrainConfig b = make_preset("paper");
  for (const auto& [k, v] : config_to_pairs(a)) set_config_value(b, k, v);
  EXPECT_EQ(config_to_pairs(a), config_to_pairs(b));
  EXPECT_EQ(b.s1.lr_offset_init, a.s1.lr_offset_init);  // bit-exact
  std::set<std::string> keys;
  for (const auto& [k, v] : config_to_pairs(a)) EXPECT_TRUE(keys.insert(k).second) << "duplicate key " << k;
}

TEST(TrainConfig, EstimatedFitSettingsOfEachPreset) {
  EXPECT_EQ(estimated_fit_settings("tiny"),
            (std::vector<std::string>{"s0.photo.steps=6000", "s0.surface.steps=2000", "s0.surface.max_in=0.015", "s0.surface.w.outside=4", "s1.lr.pose=0.005", "s3.w.opacity=0", "s3.prune_cost=0.05", "s3.depth_margin=0.01",
                                      "eval.tto_steps=100", "eval.antialias=true"}));
  // Ten times the preset's own pose rate (2e-4 in the paper preset).
  EXPECT_EQ(estimated_fit_settings("paper"),
            (std::vector<std::string>{"s0.photo.steps=6000", "s0.surface.steps=2000", "s0.surface.max_in=0.015", "s0.surface.w.outside=4", "s1.lr.pose=0.002", "s3.w.opacity=0", "s3.prune_cost=0.05", "s3.depth_margin=0.01",
                                      "eval.tto_steps=100", "eval.antialias=true"}));
  // The standard preset (512 px) the same: the image cost filters, not an opacity weight.
  EXPECT_EQ(estimated_fit_settings("standard"),
            (std::vector<std::string>{"s0.photo.steps=6000", "s0.surface.steps=2000", "s0.surface.max_in=0.015", "s0.surface.w.outside=4", "s1.lr.pose=0.005", "s3.w.opacity=0", "s3.prune_cost=0.05", "s3.depth_margin=0.01",
                                      "eval.tto_steps=100", "eval.antialias=true"}));
  EXPECT_NE(error_of([] { estimated_fit_settings("huge"); }).find("unknown preset 'huge'"), std::string::npos);
}

TEST(TrainConfig, FitsResolveFromTheSettingThenTheDataset) {
  EXPECT_TRUE(resolve_estimated_fits("auto", "estimated"));
  EXPECT_FALSE(resolve_estimated_fits("auto", "exact"));
  EXPECT_FALSE(resolve_estimated_fits("auto", ""));  // the dataset does not say: as before
  EXPECT_FALSE(resolve_estimated_fits("exact", "estimated"));
  EXPECT_TRUE(resolve_estimated_fits("estimated", ""));
  EXPECT_EQ(error_of([] { resolve_estimated_fits("maybe", "exact", "override"); }),
            "override: fits: must be auto, exact or estimated, got 'maybe'");
}

TEST(TrainConfig, RunConfigAddsTheEstimatedFitSettingsUnderTheUsersOverrides) {
  const TrainConfig tiny = make_preset("tiny");
  std::string line;
  // Estimated fits: the settings on top of the preset, everything else the preset's.
  const TrainConfig est = make_run_config("tiny", {}, "estimated", &line);
  EXPECT_EQ(est.s0.steps, 0);  // the photometric pose fit instead of the mask pre-fit
  EXPECT_EQ(est.s0.photo.steps, 6000);
  EXPECT_EQ(est.s0.surface.steps, 2000);  // the clothed surface
  EXPECT_DOUBLE_EQ(est.s1.lr_pose, 0.005);
  EXPECT_EQ(est.eval_tto_steps, 100);
  EXPECT_TRUE(est.eval_antialias);
  EXPECT_EQ(est.fits, "estimated");  // saved resolved
  TrainConfig expect = tiny;
  apply_overrides(expect, estimated_fit_settings("tiny"));
  expect.fits = "estimated";
  EXPECT_EQ(config_to_pairs(est), config_to_pairs(expect));
  EXPECT_EQ(line,
            "fits: estimated (dataset.json): s0.photo.steps=6000 s0.surface.steps=2000 s0.surface.max_in=0.015 s0.surface.w.outside=4 "
            "s1.lr.pose=0.005 s3.w.opacity=0 s3.prune_cost=0.05 "
            "s3.depth_margin=0.01 eval.tto_steps=100 eval.antialias=true "
            "(override any with key=value; fits=exact for the preset's own)");

  // The user's keys win over the settings, before and after them in the list.
  const TrainConfig mine =
      make_run_config("tiny", {"s0.photo.steps=10", "eval.antialias=false", "s1.steps=7"}, "estimated", &line);
  EXPECT_EQ(mine.s0.photo.steps, 10);
  EXPECT_FALSE(mine.eval_antialias);
  EXPECT_EQ(mine.s1.steps, 7);
  EXPECT_DOUBLE_EQ(mine.s1.lr_pose, 0.005);
  EXPECT_NE(line.find("s0.photo.steps=10 (yours)"), std::string::npos) << line;
  EXPECT_NE(line.find("eval.antialias=false (yours)"), std::string::npos) << line;

  // fits=exact keeps the preset whatever the dataset says; so do exact and unflagged data.
  for (const auto& [kv, data] : std::vector<std::pair<std::string, std::string>>{
           {"fits=exact", "estimated"}, {"fits=auto", "exact"}, {"fits=auto", ""}}) {
    TrainConfig c = make_run_config("tiny", {kv}, data, &line);
    EXPECT_EQ(c.fits, "exact") << kv << " " << data;
    c.fits = tiny.fits;
    EXPECT_EQ(config_to_pairs(c), config_to_pairs(tiny)) << kv << " " << data;
    EXPECT_EQ(line.rfind("fits: exact (", 0), 0u) << line;
  }
  EXPECT_EQ(line, "fits: exact (dataset.json does not say): the preset's settings (fits=estimated for those of "
                  "estimated fits)");
  // fits=estimated on data that says exact (or nothing).
  EXPECT_TRUE(make_run_config("paper", {"fits=estimated"}, "exact", &line).eval_antialias);
  EXPECT_EQ(line.rfind("fits: estimated (fits=estimated): s0.photo.steps=6000 s0.surface.steps=2000 s0.surface.max_in=0.015 s0.surface.w.outside=4 s1.lr.pose=0.002 ", 0), 0u) << line;
  // A bad value: one line naming the key, whatever the data.
  EXPECT_EQ(error_of([] { make_run_config("tiny", {"fits=guess"}, "estimated"); }),
            "override: fits: must be auto, exact or estimated, got 'guess'");
}

}  // namespace
}  // namespace haha
