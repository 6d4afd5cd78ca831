// File side of `haha eval`: the stage table and per-frame metrics as RUN/report.json and
// RUN/report.md, and the contact sheet of test frames (ground truth, render, error map,
// Gaussian layer, mesh layer).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "render/texture_speckle.h"
#include "train/evaluate.h"

namespace haha {

struct EvalReport {
  std::string run_dir, data_dir, split = "test", background = "black", preset;
  int tto_steps = 0;
  int tto_resolution = 0;      // 3/4 of the test-time pose steps at this side (0 = all at the scored size)
  int width = 0, height = 0;   // the size the frames were scored at
  int train_resolution = 0;    // the longer side the run trained at
  bool antialias = false;  // mesh silhouette antialiased (haha eval --antialias)
  bool lpips_available = false;
  std::vector<std::string> switches;     // e.g. "use_sobel=false"
  std::array<double, 3> stage_seconds{0, 0, 0};  // training wall time per stage (0 = unknown)
  std::vector<VariantEval> variants;     // mesh only, full Gaussians, naive merge, HAHA filtered
  std::vector<std::string> frame_names;  // per evaluated frame
  std::string part;                      // non-empty: VariantEval::psnr_part is over this part's pixels
  std::vector<int> regions_full, regions_filtered;  // Gaussians per BodyRegion
  double eval_seconds = 0;
  // The HAHA avatar's texture where the video barely looked (render/texture_speckle.h), and
  // the share of its chart texels below s2.evidence.full (-1: no RUN/texture_evidence.npy).
  bool has_speckle = false;
  TextureSpeckle speckle;
  double evidence_full = 0, low_evidence_share = -1;
};

// The method's claims checked on variants [mesh, full, naive, filtered]:
// filtered count <= full / 2, PSNR(filtered) >= PSNR(full) - 0.5, >= PSNR(mesh) + 1.
struct EvalChecks {
  bool complete = false;  // the report has the mesh, full and HAHA rows the checks compare
  bool count_ok = false, psnr_vs_full_ok = false, psnr_vs_mesh_ok = false;
  double count_ratio = 0, psnr_minus_full = 0, psnr_minus_mesh = 0;
};
EvalChecks eval_checks(const EvalReport& r);

std::string eval_report_json(const EvalReport& r);
std::string eval_report_markdown(const EvalReport& r);
// report.json + report.md into dir, or r.run_dir when dir is empty (atomic).
void write_eval_report(const EvalReport& r, const std::string& dir = "");

// Rows of [ground truth | HAHA render | error x4 | Gaussian layer | mesh only | full
// Gaussians] for the frames whose images were kept. Written atomically as PNG.
void write_eval_contact_sheet(const std::string& path, const EvalReport& r, int width, int height);

}  // namespace haha
