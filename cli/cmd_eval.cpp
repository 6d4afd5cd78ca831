// `haha eval`: the paper's stage table for a trained run (app/eval_run.h), written to
// RUN/report.json, RUN/report.md and RUN/eval_sheet.png, or into --out.
#include <cstdio>
#include <memory>
#include <string>

#include "app/eval_run.h"
#include "command.h"

HAHA_COMMAND(eval) {
  struct Opts {
    haha::EvalRunOptions run;
    bool json = false, antialias = false, no_antialias = false;
  };
  auto a = std::make_shared<Opts>();
  haha::EvalRunOptions& r = a->run;
  auto* sub = app.add_subcommand("eval", "Evaluate a trained run: mesh only / full Gaussians / naive merge / HAHA");
  sub->add_option("--run", r.run_dir, "run directory (haha train --out)")->required();
  sub->add_option("--data", r.data_dir, "dataset directory (default: the run's)");
  sub->add_option("--out", r.out_dir, "folder for report.json, report.md and eval_sheet.png (default: the run directory)");
  sub->add_option("--split", r.split,
                  "train, test or unseen (the views the turn never showed: haha synth --unseen)")->capture_default_str();
  sub->add_option("--background", r.background, "black or white")->capture_default_str();
  sub->add_option("--tto-steps", r.tto_steps,
                  "test-time pose optimisation steps (default: the run's eval.tto_steps; 0 = off)");
  sub->add_option("--tto-resolution", r.tto_resolution,
                  "test-time pose optimisation coarse to fine: 3/4 of its steps on the frames downscaled to this "
                  "longer side, the rest at the scored size (default: the run's eval.tto_resolution; 0 = all at the "
                  "scored size)");
  sub->add_option("--variants", r.variants,
                  "evaluate only these rows of the table: mesh, full, naive, haha (comma separated; default all; "
                  "the requirement checks need mesh, full and haha)")
      ->delimiter(',');
  sub->add_option("--depth-margin", r.depth_margin,
                  "score the merge with Gaussians up to this many metres behind the mesh visible (default: the run's "
                  "s3.depth_margin)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--pose-from", r.pose_from,
                  "score this variant first (mesh, full, naive or haha) and every other one at the poses its "
                  "test-time optimisation found, so that the rows differ only in the avatar (default: each "
                  "variant fits its own)");
  sub->add_option("--coverage-oracle", r.coverage_oracle,
                  "diagnostic of a learned mesh coverage: pixel (the mesh cut to each frame's true matte, no depth "
                  "test outside it: the ceiling of any coverage) or texel (a 0/1 coverage per texel from where the "
                  "mesh-only row's texels fell outside the matte: the ceiling of a texture alpha)");
  sub->add_option("--frames", r.frames, "evaluate only the first N frames of the split (0 = all)");
  sub->add_option("--resolution", r.resolution,
                  "score at this longer image side in px, any size (default: the size the run trained at)");
  sub->add_option("--part", r.part,
                  "garment: also report the PSNR over the garment's pixels, weighted by the dataset's part masks "
                  "(haha synth --part-masks)");
  sub->add_option("--sheet-frames", r.sheet_frames, "frames on the contact sheet")->capture_default_str();
  sub->add_option("--lpips-weights", r.lpips_weights, "LPIPS weight file (AlexNet part used); default: the run's");
  auto* aa = sub->add_flag("--antialias", a->antialias,
                           "antialias the mesh silhouette in test-time pose optimisation and the final render "
                           "(default: the run's eval.antialias, true for estimated fits)");
  sub->add_flag("--no-antialias", a->no_antialias, "the mesh silhouette as rasterized, whatever the run says")
      ->excludes(aa);
  sub->add_flag("--json", a->json, "print report.json instead of the table");
  sub->callback([a] {
    a->run.print_table = !a->json;
    a->run.antialias = a->antialias ? 1 : a->no_antialias ? 0 : -1;
    const haha::EvalReport rep = haha::run_eval(a->run);
    if (a->json)
      std::printf("%s", haha::eval_report_json(rep).c_str());
    else
      std::printf("%s\nwrote %s/report.md, report.json, eval_sheet.png (%.1f s)\n",
                  haha::eval_report_markdown(rep).c_str(),
                  (a->run.out_dir.empty() ? rep.run_dir : a->run.out_dir).c_str(), rep.eval_seconds);
  });
}
