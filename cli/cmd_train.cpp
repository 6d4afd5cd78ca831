// `haha train`: the three HAHA stages on a native dataset (app/train_run.h).
#include <memory>
#include <string>
#include <vector>

#include "app/train_run.h"
#include "command.h"
#include "train/config.h"

HAHA_COMMAND(train) {
  struct Opts {
    haha::TrainRunOptions run;
    bool list = false, no_sobel = false, no_opacity_reg = false, no_dice = false;
    int64_t stop_after = -1;
  };
  auto a = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("train", "Train a HAHA avatar (Gaussians + textured mesh) on a dataset");
  sub->add_option("--data", a->run.data_dir, "dataset directory (haha synth / haha convert)");
  sub->add_option("--model", a->run.model_path, "body model .npz (default: DATA/body_model.npz)");
  sub->add_option("--out", a->run.run_dir, "run directory (config, checkpoints, avatar); required");
  sub->add_option("--preset", a->run.preset, "tiny (128 px, the demo), standard (the video's size up to 512 px, the texture coarse to fine: "
                  "real use on a CPU) or paper (the published schedule, for a GPU)")
      ->capture_default_str();
  sub->add_flag("--resume", a->run.resume, "continue the run in --out from its last checkpoint");
  sub->add_option("--device", a->run.device,
                  "cpu, cuda (every stage on the GPU) or auto (cuda where a GPU answers); a run may resume on "
                  "another device")
      ->capture_default_str();
  sub->add_option("--lpips-weights", a->run.lpips_weights,
                  "LPIPS weight file (.npz, layout in train/lpips.h); without it LPIPS is off");
  sub->add_flag("--no-sobel", a->no_sobel, "ablation: no edge loss");
  sub->add_flag("--no-opacity-reg", a->no_opacity_reg, "ablation: no opacity regulariser");
  sub->add_flag("--no-dice", a->no_dice, "ablation: no silhouette Dice");
  sub->add_option("--stop-after", a->stop_after, "stop after this many steps (checkpointed; for --resume)");
  sub->add_flag("--list-keys", a->list, "print every config key with its value in the preset and exit");
  sub->add_option("overrides", a->run.overrides, "key=value overrides of the preset (see --list-keys)");
  sub->callback([a] {
    if (a->list) {
      haha::TrainConfig c = haha::make_preset(a->run.preset);
      haha::apply_overrides(c, a->run.overrides);
      for (const haha::ConfigEntry& e : haha::config_entries(c))
        std::printf("%-24s %-14s %s\n", e.key.c_str(), haha::config_value_string(e).c_str(), e.help.c_str());
      return;
    }
    if (a->no_sobel) a->run.overrides.push_back("use_sobel=false");
    if (a->no_opacity_reg) a->run.overrides.push_back("use_opacity_reg=false");
    if (a->no_dice) a->run.overrides.push_back("use_dice=false");
    a->run.stop_after = a->stop_after;
    haha::run_training(a->run);
  });
}
