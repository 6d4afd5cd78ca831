// Training config: presets, key=value overrides, errors, round trip through text.
#include <gtest/gtest.h>

#include <set>

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

}  // namespace
}  // namespace haha
