// `haha bench`: speed and size against error on one trained run (app/bench_run.h).
#include <memory>

#include "app/bench_run.h"
#include "command.h"

HAHA_COMMAND(bench) {
  auto o = std::make_shared<haha::BenchRunOptions>();
  auto* sub = app.add_subcommand("bench", "Speed and size against error on a trained run: bench.json, bench.md, PNG plots");
  sub->add_option("--run", o->run, "run directory (haha train --out; haha eval not needed)");
  sub->add_option("--replot", o->replot,
                  "redraw bench.md and the plots of an earlier bench directory from its bench.json (no measuring)");
  sub->add_option("--data", o->data, "dataset directory (default: the run's)");
  sub->add_option("--out", o->out, "output directory");
  sub->add_option("--device", o->device, "cpu or cuda (render timings also on the GPU)")->capture_default_str();
  sub->add_option("--split", o->split, "frames the quality numbers are measured on: test or train")->capture_default_str();
  sub->add_option("--frames", o->frames, "use only the first N frames of the split (0 = all)");
  sub->add_option("--resolution", o->resolution,
                  "longer side the quality frames are scored at in px (default: the size the run trained at)");
  sub->add_option("--tto-steps", o->tto_steps,
                  "test-time pose optimisation steps per frame and avatar (0: every avatar on the same poses)")
      ->capture_default_str();
  sub->add_option("--opacity-weights", o->weights,
                  "stage-3 opacity-regulariser weights to re-run stage 3 with (default: 0 and the run's weight w x 0.1, 1, 10, "
                  "100; w itself is read off the trained avatar, not re-run; a run that filters by the image cost, "
                  "s3.prune_cost without an opacity weight, re-runs its cost x 0.2, 0.5, 2 and 5 instead)");
  sub->add_option("--retrain-steps", o->retrain_steps,
                  "stage-3 steps of the re-runs (default: the run's; a shorter stage 3 re-runs the run's weight too)");
  sub->add_option("--prune-thresholds", o->thresholds,
                  "opacity thresholds for pruning the trained avatar (default: the run's s3.prune_threshold, then 0.15 .. 0.9)");
  sub->add_option("--resolutions", o->resolutions, "image sides of the render-speed sweep")->capture_default_str();
  sub->add_option("--count-resolution", o->count_resolution, "image side of the Gaussian-count sweep")->capture_default_str();
  sub->add_option("--render-threads", o->threads, "CPU thread counts of the render sweep (default: 1 and all)");
  sub->add_option("--repeats", o->repeats, "timed renders per point (median reported)")->capture_default_str();
  sub->add_option("--skip", o->skip, "sections to leave out: training,filtering,retrain,packing,render");
  sub->add_option("--gaussian-bit-sets", o->gaussian_bit_sets,
                  "extra packing points with per-attribute Gaussian bits, ';'-separated, e.g. \"offset=10,rotation=6;offset=12\"");
  sub->add_option("--mesh-bit-sets", o->mesh_bit_sets,
                  "extra packing points with mesh Draco bits, ';'-separated, e.g. \"position=14;position=15,weight=8\"");
  sub->add_option("--corrective-sets", o->corrective_sets,
                  "extra packing points with pose correctives: none, dense or a compact codec, ';'-separated, e.g. "
                  "\"none;t=0.05,r=2,b=8;t=0.1,r=1,b=6\"");
  sub->callback([o] { haha::run_bench(*o); });
}
