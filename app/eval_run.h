// `haha eval`: the paper's stage table for a trained run (train/evaluate.h): mesh only /
// full Gaussians / naive merge / HAHA filtered on held-out frames, written to
// RUN/report.json, RUN/report.md and RUN/eval_sheet.png (app/eval_report.h), or into another
// folder (out_dir: evaluating a run on other data keeps the run's own report).
#pragma once

#include <string>
#include <vector>

#include "app/eval_report.h"

namespace haha {

struct EvalRunOptions {
  std::string run_dir;
  std::string data_dir;              // empty: the run's dataset
  std::string out_dir;               // where the report files go; empty: the run directory
  std::string split = "test";        // train | test | unseen (haha synth --unseen)
  std::string background = "black";  // black | white
  int tto_steps = -1;                // test-time pose optimisation steps; < 0: the run's
  int tto_resolution = -1;           // coarse side of test-time pose optimisation (0 = all at the scored size); < 0: the run's
  int frames = 0;                    // > 0: only the first N frames of the split
  int resolution = 0;                // longer side the frames are scored at; 0: the run's training size
  int sheet_frames = 4;              // frames on the contact sheet
  std::string part;                  // "garment": also PSNR over the dataset's part masks (haha synth --part-masks); empty: none
  std::string lpips_weights;         // empty: the run's (AlexNet part used)
  std::vector<std::string> variants;  // rows to evaluate (kPaperVariantKeys); empty: all four
  bool print_table = true;           // one line per variant on stdout while it runs
  double depth_margin = -1;          // metres of the merge's depth test; < 0: the run's (s3.depth_margin)
  // A variant key (kPaperVariantKeys): that variant is scored first (added to `variants` if
  // missing) and every other one at the poses its test-time optimisation found. Empty: each
  // variant fits its own poses.
  std::string pose_from;
  // EvalOptions::coverage_oracle (a diagnostic): "pixel" or "texel" ("texel" adds the mesh row,
  // scored before the merges); empty: none.
  std::string coverage_oracle;
  int antialias = -1;                // antialiased mesh silhouette (EvalOptions::antialias): 1 on
                                     // (--antialias), 0 off (--no-antialias), -1 the run's eval.antialias
};

// Evaluates the four variants, writes the report files and returns the report.
// Throws haha::Error naming the file or option for bad input.
EvalReport run_eval(const EvalRunOptions& opt);

}  // namespace haha
