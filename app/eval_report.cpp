#include "app/eval_report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "app/run_dir.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "data/contact_sheet.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

ojson num(double v) { return std::isfinite(v) ? ojson(v) : ojson(nullptr); }

std::string f2(double v, const char* fmt) {
  char b[64];
  if (!std::isfinite(v)) return "n/a";
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}

}  // namespace

EvalChecks eval_checks(const EvalReport& r) {
  EvalChecks c;
  const VariantEval *m = nullptr, *fu = nullptr, *fi = nullptr;
  for (const VariantEval& v : r.variants) {
    if (v.paper_row == 0) m = &v;
    if (v.paper_row == 1) fu = &v;
    if (v.paper_row == 3) fi = &v;
  }
  if (!m || !fu || !fi) return c;  // some rows were not evaluated (--variants): no checks
  c.complete = true;
  const VariantEval &mesh = *m, &full = *fu, &filt = *fi;
  c.count_ratio = full.num_gaussians > 0 ? double(filt.num_gaussians) / full.num_gaussians : 0;
  c.psnr_minus_full = filt.psnr - full.psnr;
  c.psnr_minus_mesh = filt.psnr - mesh.psnr;
  c.count_ok = 2 * int64_t(filt.num_gaussians) <= int64_t(full.num_gaussians);
  c.psnr_vs_full_ok = c.psnr_minus_full >= -0.5;
  c.psnr_vs_mesh_ok = c.psnr_minus_mesh >= 1.0;
  return c;
}

std::string eval_report_json(const EvalReport& r) {
  ojson j;
  j["run"] = r.run_dir;
  j["data"] = r.data_dir;
  j["split"] = r.split;
  j["background"] = r.background;
  j["preset"] = r.preset;
  j["tto_steps"] = r.tto_steps;
  j["tto_resolution"] = r.tto_resolution;
  j["resolution"] = {r.width, r.height};
  j["train_resolution"] = r.train_resolution;
  j["antialias"] = r.antialias;
  j["lpips"] = r.lpips_available ? ojson("AlexNet (user-supplied weights)") : ojson(kLpipsUnavailable);
  j["switches"] = r.switches;
  if (!r.part.empty()) j["part"] = r.part;
  j["eval_seconds"] = r.eval_seconds;
  j["stage_train_seconds"] = {r.stage_seconds[0], r.stage_seconds[1], r.stage_seconds[2]};
  if (r.has_speckle) {
    ojson t;
    for (int p = 0; p < kSpeckleParts; ++p) t["speckle_per_mille"][speckle_part_name(p)] = r.speckle.per_mille[size_t(p)];
    t["speckle_per_mille"]["all_charts"] = r.speckle.all_per_mille;
    if (r.low_evidence_share >= 0)
      t["evidence_full"] = r.evidence_full, t["low_evidence_share"] = r.low_evidence_share;
    j["texture"] = t;
  }
  ojson rows = ojson::array();
  for (size_t i = 0; i < r.variants.size(); ++i) {
    const VariantEval& v = r.variants[i];
    ojson row;
    row["name"] = v.name;
    row["key"] = kPaperVariantKeys[v.paper_row];
    row["mesh"] = v.mesh;
    row["gaussians_layer"] = v.gaussians;
    row["gaussians"] = v.num_gaussians;
    row["storage_bytes"] = v.storage_bytes;
    row["psnr"] = num(v.psnr);
    row["psnr_outline"] = num(v.psnr_outline);
    row["psnr_person"] = num(v.psnr_person);
    if (!r.part.empty()) row["psnr_part"] = num(v.psnr_part), row["transmittance_part"] = num(v.transmittance_part);
    row["ssim"] = num(v.ssim);
    row["lpips"] = v.lpips >= 0 ? num(v.lpips) : ojson(nullptr);
    row["render_ms"] = num(v.render_ms);
    row["train_seconds"] = num(variant_train_seconds(r.stage_seconds, v.paper_row));
    ojson fr = ojson::array();
    for (size_t k = 0; k < v.frames.size(); ++k) {
      const FrameEval& f = v.frames[k];
      ojson o;
      o["frame"] = k < r.frame_names.size() ? r.frame_names[k] : std::to_string(k);
      o["psnr"] = num(f.psnr);
      o["psnr_outline"] = num(f.psnr_outline);
      o["psnr_person"] = num(f.psnr_person);
      if (!r.part.empty()) o["psnr_part"] = num(f.psnr_part), o["transmittance_part"] = num(f.transmittance_part);
      o["ssim"] = num(f.ssim);
      o["lpips"] = f.lpips >= 0 ? num(f.lpips) : ojson(nullptr);
      o["render_ms"] = num(f.render_ms);
      o["tto_loss_start"] = num(f.tto_loss_start);
      o["tto_loss_end"] = num(f.tto_loss_end);
      fr.push_back(o);
    }
    row["frames"] = fr;
    rows.push_back(row);
  }
  j["variants"] = rows;
  ojson reg = ojson::array();
  for (size_t k = 0; k < size_t(BodyRegion::count); ++k) {
    ojson o;
    o["region"] = region_name(BodyRegion(k));
    o["full"] = k < r.regions_full.size() ? r.regions_full[k] : 0;
    o["filtered"] = k < r.regions_filtered.size() ? r.regions_filtered[k] : 0;
    reg.push_back(o);
  }
  j["regions"] = reg;
  const EvalChecks c = eval_checks(r);
  if (c.complete)
    j["checks"] = {{"filtered_count_ratio", c.count_ratio},
                 {"filtered_at_most_half", c.count_ok},
                 {"psnr_filtered_minus_full", num(c.psnr_minus_full)},
                 {"psnr_within_0_5_db_of_full", c.psnr_vs_full_ok},
                 {"psnr_filtered_minus_mesh", num(c.psnr_minus_mesh)},
                 {"psnr_1_db_above_mesh", c.psnr_vs_mesh_ok}};
  return j.dump(2) + "\n";
}

std::string eval_report_markdown(const EvalReport& r) {
  std::string s;
  s += "# HAHA evaluation: " + r.run_dir + "\n\n";
  s += "Data: `" + r.data_dir + "`, split " + r.split + ", " + std::to_string(r.frame_names.size()) +
       " frames scored at " + std::to_string(r.width) + "x" + std::to_string(r.height) + " px (trained at " +
       std::to_string(r.train_resolution) + " px on the longer side), background " + r.background + ", test-time pose optimisation " + std::to_string(r.tto_steps) +
       " steps" +
       (r.tto_steps > 0 && r.tto_resolution > 0 && r.tto_resolution < std::max(r.width, r.height)
            ? " (3/4 of them at " + std::to_string(r.tto_resolution) + " px)"
            : std::string()) + (r.antialias ? std::string(", antialiased mesh silhouette") : std::string()) + ", preset " +
       r.preset + ".\n";
  s += "LPIPS: " + std::string(r.lpips_available ? "AlexNet, user-supplied weights" : kLpipsUnavailable) + ".\n";
  if (!r.switches.empty()) {
    s += "Switches:";
    for (const std::string& w : r.switches) s += " `" + w + "`";
    s += "\n";
  }
  s += "\n| variant | Gaussians | storage (MB) | PSNR | person PSNR | outline PSNR | SSIM | LPIPS | render (ms) | train (s) |\n";
  s += "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (size_t i = 0; i < r.variants.size(); ++i) {
    const VariantEval& v = r.variants[i];
    s += "| " + v.name + " | " + std::to_string(v.num_gaussians) + " | " + f2(v.storage_bytes / 1e6, "%.3f") + " | " +
         f2(v.psnr, "%.2f") + " | " + f2(v.psnr_person, "%.2f") + " | " + f2(v.psnr_outline, "%.2f") + " | " + f2(v.ssim, "%.4f") + " | " + (v.lpips >= 0 ? f2(v.lpips, "%.4f") : "n/a") +
         " | " + f2(v.render_ms, "%.1f") + " | " + f2(variant_train_seconds(r.stage_seconds, v.paper_row), "%.0f") + " |\n";
  }
  if (!r.part.empty()) {
    s += "\nPSNR over the " + r.part + "'s pixels (weighted by the dataset's part masks):";
    for (const VariantEval& v : r.variants) s += " " + v.name + " " + f2(v.psnr_part, "%.2f") + " dB;";
    s.back() = '.';
    s += "\nTransmittance over the " + r.part + "'s pixels (background showing through the render):";
    for (const VariantEval& v : r.variants) s += " " + v.name + " " + f2(100 * v.transmittance_part, "%.2f") + "%;";
    s.back() = '.';
    s += "\n";
  }
  if (r.has_speckle) {
    s += "\nTexture speckle (chart texels > " + f2(kSpeckleStep, "%.2f") + " luminance off their 5x5 median, per mille): neck " +
         f2(r.speckle.per_mille[0], "%.1f") + ", hands " + f2(r.speckle.per_mille[1], "%.1f") + ", feet " +
         f2(r.speckle.per_mille[2], "%.1f") + " (all charts " + f2(r.speckle.all_per_mille, "%.1f") + ").";
    if (r.low_evidence_share >= 0)
      s += " Chart texels seen less than " + f2(r.evidence_full, "%g") + " frontal pixel(s): " +
           f2(100 * r.low_evidence_share, "%.1f") + "%.";
    s += "\n";
  }
  s += "\nStorage: 56 bytes per Gaussian (14 float32) + 4 bytes face index, texture as 8-bit RGB.\n";
  s += "Person PSNR: over the pixels where the ground-truth mask exceeds 0.5 (the background left out).\n";
  s += "Outline PSNR: within " + std::to_string(kOutlineBandPx) +
       " px of the person's outline in the ground-truth mask (where a backdrop's colour or a wrong silhouette shows).\n";
  s += "Render time: LBS + rasterization of one frame on this machine's CPU.\n";
  s += "\n## Gaussians per body region (dominant skinning joint of the parent face)\n\n";
  s += "| region | full | filtered | kept |\n|---|---:|---:|---:|\n";
  for (size_t k = 0; k < size_t(BodyRegion::count); ++k) {
    const int a = k < r.regions_full.size() ? r.regions_full[k] : 0;
    const int b = k < r.regions_filtered.size() ? r.regions_filtered[k] : 0;
    s += "| " + std::string(region_name(BodyRegion(k))) + " | " + std::to_string(a) + " | " + std::to_string(b) +
         " | " + (a > 0 ? f2(100.0 * b / a, "%.0f%%") : std::string("-")) + " |\n";
  }
  const EvalChecks c = eval_checks(r);
  if (c.complete) {
    s += "\n## Requirements\n\n";
    s += std::string("- filtered keeps <= half of the full-Gaussian count: ") + (c.count_ok ? "PASS" : "FAIL") + " (" +
         f2(100 * c.count_ratio, "%.1f") + "%)\n";
    s += std::string("- PSNR within 0.5 dB of full Gaussians: ") + (c.psnr_vs_full_ok ? "PASS" : "FAIL") + " (" +
         f2(c.psnr_minus_full, "%+.2f") + " dB)\n";
    s += std::string("- PSNR >= 1 dB above the textured mesh: ") + (c.psnr_vs_mesh_ok ? "PASS" : "FAIL") + " (" +
         f2(c.psnr_minus_mesh, "%+.2f") + " dB)\n";
  }
  s += "\n## Per frame (PSNR)\n\n| frame |";
  for (const VariantEval& v : r.variants) s += " " + v.name + " |";
  s += "\n|---|";
  for (size_t i = 0; i < r.variants.size(); ++i) s += "---:|";
  s += "\n";
  for (size_t k = 0; k < r.frame_names.size(); ++k) {
    s += "| " + fs::path(r.frame_names[k]).filename().string() + " |";
    for (const VariantEval& v : r.variants) s += " " + (k < v.frames.size() ? f2(v.frames[k].psnr, "%.2f") : "") + " |";
    s += "\n";
  }
  return s;
}

void write_eval_report(const EvalReport& r, const std::string& dir) {
  const RunDir run(dir.empty() ? r.run_dir : dir);
  write_text_file(run.report_json(), eval_report_json(r));
  write_text_file(run.report_md(), eval_report_markdown(r));
}

void write_eval_contact_sheet(const std::string& path, const EvalReport& r, int width, int height) {
  if (r.variants.empty()) fail(path, "no evaluated variant");
  const VariantEval& haha = r.variants.back();
  const VariantEval *mesh = nullptr, *full = nullptr;
  for (const VariantEval& v : r.variants) {
    if (v.mesh && !v.gaussians) mesh = &v;
    if (!v.mesh && v.gaussians) full = &v;
  }
  std::vector<ContactSheetTile> tiles;
  auto img = [&](const std::vector<float>& d) {
    Image im(width, height, 3);
    if (d.size() == im.data.size()) im.data = d;
    return im;
  };
  for (size_t k = 0; k < haha.frames.size(); ++k) {
    const FrameEval& f = haha.frames[k];
    if (f.image.empty()) continue;
    Image err(width, height, 3);
    for (size_t p = 0; p < size_t(width) * height; ++p) {
      float e = 0;
      for (int c = 0; c < 3; ++c) e += std::fabs(f.image[3 * p + c] - f.ground_truth[3 * p + c]) / 3.0f;
      e = std::min(1.0f, 4.0f * e);  // x4: small errors visible
      err.data[3 * p] = e;           // hot colour map: black -> red -> yellow
      err.data[3 * p + 1] = std::max(0.0f, 2.0f * e - 1.0f);
      err.data[3 * p + 2] = 0.0f;
    }
    char psnr[32];
    std::snprintf(psnr, sizeof psnr, "HAHA %.2f DB", f.psnr);
    tiles.push_back({img(f.ground_truth), "GT " + std::to_string(k), true});
    tiles.push_back({img(f.image), psnr, false});
    tiles.push_back({std::move(err), "ERROR X4", false});
    tiles.push_back({img(f.gaussian_layer), "GAUSSIANS", false});
    if (mesh && k < mesh->frames.size() && !mesh->frames[k].image.empty()) {
      char mp[32];
      std::snprintf(mp, sizeof mp, "MESH %.2f DB", mesh->frames[k].psnr);
      tiles.push_back({img(mesh->frames[k].image), mp, false});
    } else {
      tiles.push_back({img(f.mesh_layer), "MESH LAYER", false});
    }
    if (full && k < full->frames.size() && !full->frames[k].image.empty()) {
      char fp[32];
      std::snprintf(fp, sizeof fp, "FULL GS %.2f DB", full->frames[k].psnr);
      tiles.push_back({img(full->frames[k].image), fp, false});
    }
  }
  if (tiles.empty()) fail(path, "no frame images were kept");
  ContactSheetOptions o;
  o.columns = full ? 6 : 5;
  o.title = "GT | HAHA | ERROR | GAUSSIAN LAYER | MESH ONLY | FULL GAUSSIANS   (" + fs::path(r.run_dir).filename().string() +
            ", " + std::to_string(width) + "X" + std::to_string(height) + " PX)";
  o.label_scale = width >= 256 ? 2 : 1;
  write_contact_sheet(path, tiles, o);
}

}  // namespace haha
