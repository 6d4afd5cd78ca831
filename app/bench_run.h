// `haha bench`: speed and size against error on one trained run (bench/bench_sweeps.h):
// the stage table with training wall times, the Gaussian budget (stage 3 re-run with
// several opacity-regulariser weights, and pruning thresholds), packing settings, and
// render speed against resolution / Gaussian count / threads. Writes OUT/bench.json,
// OUT/bench.md and OUT/plots/*.png (bench/bench_report.h).
#pragma once

#include <string>

#include "bench/bench_report.h"

namespace haha {

struct BenchRunOptions {
  std::string run;     // run directory (haha train --out)
  std::string replot;  // instead: redraw an earlier bench directory from its bench.json
  std::string data;    // dataset directory; empty: the run's
  std::string out;     // output directory
  std::string device = "cpu", split = "test";
  std::string skip;           // sections to leave out: training,filtering,retrain,packing,render
  std::string weights;        // stage-3 opacity weights to re-run, comma-separated (empty: default set)
  std::string thresholds;     // opacity pruning thresholds, comma-separated (empty: default set)
  std::string resolutions = "128,256,512,1024";
  std::string threads;        // CPU thread counts of the render sweep (empty: 1 and all)
  // Extra packing points: per-attribute Gaussian bits, ';'-separated ("offset=10,rotation=6;...").
  std::string gaussian_bit_sets;
  std::string mesh_bit_sets;    // extra packing points: mesh Draco bits, ';'-separated
  std::string corrective_sets;  // extra packing points: pose-corrective codecs, ';'-separated
  int frames = 0, tto_steps = 0, repeats = 5, count_resolution = 512, retrain_steps = 0;
  int resolution = 0;  // longer side of the frames quality is measured on; 0: the run's training size
};

// Measures, writes OUT/bench.json, bench.md and the plots, prints progress lines, and
// returns what it measured. Throws haha::Error naming the option or file for bad input.
BenchResult run_bench(const BenchRunOptions& o);

}  // namespace haha
