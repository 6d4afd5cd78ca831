// File side of `haha bench`: the measurements of bench/bench_sweeps.h as OUT/bench.json,
// OUT/bench.md and PNG plots (bench/plot.h) under OUT/plots/, each plot stating the machine.
//
// bench.json (every number finite):
//   {"format": "haha-bench", "version": 1, "machine": {cpu_model, logical_cpus, threads, gpu,
//    load_average, omp_wait_policy},
//    "run", "data", "preset", "device", "date", "eval": {frames, resolution, tto_steps},
//    "training": {stage_seconds[3], stage_steps[3], rows: [{name, gaussians, storage_bytes,
//                 psnr, ssim, render_ms, train_seconds}]},
//    "filtering": [{method, strength, gaussians, storage_bytes, psnr, ssim, render_ms, stage3_seconds}],
//    "packing": [{name, group, lossless, gaussian_bits, gaussian_bits_spec, mesh_bits_spec, texture_codec, texture_quality,
//                 texture_size, bytes, gaussian_bytes, texture_bytes, mesh_bytes, pack_ms,
//                 decode_ms, psnr_vs_original, identical, psnr, ssim, psnr_cost}],
//    "render": [{sweep, device, threads, resolution, gaussians, mesh, ms_median, ms_min, repeats}],
//    "seconds": {section: wall seconds}, "plots": [file names], "notes": [text]}
#pragma once

#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "bench/bench_sweeps.h"
#include "bench/plot.h"

namespace haha {

struct BenchResult {
  MachineInfo machine;
  std::string run_dir, data_dir, preset, device = "cpu", date;
  int eval_frames = 0, eval_resolution = 0, tto_steps = 0;
  std::array<double, 3> stage_seconds{0, 0, 0};
  std::array<int, 3> stage_steps{0, 0, 0};
  std::vector<StageRow> stages;       // training time against quality
  std::vector<FilterPoint> filtering; // both methods
  std::vector<PackPoint> packing;
  std::vector<RenderTiming> render;
  std::map<std::string, double> seconds;  // wall time of each section of the bench
  std::vector<std::string> notes;         // how the numbers were taken
};

// "2025-01-31 12:34 UTC" (now).
std::string bench_date();

// The plots as specifications (file name, spec), for the sections that have data.
std::vector<std::pair<std::string, PlotSpec>> bench_plots(const BenchResult& r);

std::string bench_json(const BenchResult& r, const std::vector<std::string>& plot_files);
std::string bench_markdown(const BenchResult& r, const std::vector<std::string>& plot_files);

// Reads a bench.json back (for `haha bench --replot`: new plots and Markdown from the
// numbers already measured). Throws haha::Error "<path>: <key>: <problem>".
BenchResult read_bench_json(const std::string& path);

// Writes out_dir/plots/*.png (+ their .gp scripts), out_dir/bench.json and bench.md, all
// atomically. Returns the plot paths. Throws haha::Error naming the file on failure
// (gnuplot missing included: the JSON and Markdown are still written first).
std::vector<std::string> write_bench_report(const std::string& out_dir, const BenchResult& r);

}  // namespace haha
