#include "bench/bench_report.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {

namespace {

using ojson = nlohmann::ordered_json;

// JSON numbers must be finite; a NaN / Inf measurement becomes null (and is a bug to report).
ojson num(double v) { return std::isfinite(v) ? ojson(v) : ojson(nullptr); }

std::string f(const char* fmt, double v) {
  char b[64];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}

std::string kb(double bytes) { return f("%.1f", bytes / 1024.0); }


std::string subtitle(const BenchResult& r) {
  std::string load;
  if (r.machine.load_average >= 0) load = f(", load %.1f at start", r.machine.load_average);
  load += ", OMP_WAIT_POLICY " + (r.machine.omp_wait_policy.empty() ? std::string("default") : r.machine.omp_wait_policy);
  return "machine: " + r.machine.line() + load + "\nrun " + r.run_dir + " (" + r.preset + "), " +
         std::to_string(r.eval_frames) + " test frames at " + std::to_string(r.eval_resolution) + " px, " + r.date;
}

std::string short_num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

using Plots = std::vector<std::pair<std::string, PlotSpec>>;

// A plot's title with `sub` (the machine and the run) under it, its axes and where its key goes.
PlotSpec plot_spec(const std::string& title, const std::string& sub, const std::string& xlabel,
                   const std::string& ylabel, const std::string& key) {
  PlotSpec p;
  p.title = title;
  p.subtitle = sub;
  p.xlabel = xlabel;
  p.ylabel = ylabel;
  p.key = key;
  return p;
}

// Storage is linear in the count (train/evaluate.h storage_bytes): the line read off two
// points with different counts; 0 per Gaussian when there are no two.
struct StorageLine {
  double kb_per_gaussian = 0, kb_offset = 0;
};

StorageLine storage_line(const std::vector<FilterPoint>& filtering) {
  StorageLine line;
  for (const FilterPoint& a : filtering)
    for (const FilterPoint& b : filtering)
      if (line.kb_per_gaussian == 0 && b.q.gaussians > a.q.gaussians) {
        line.kb_per_gaussian = double(b.q.storage_bytes - a.q.storage_bytes) / double(b.q.gaussians - a.q.gaussians) / 1024.0;
        line.kb_offset = double(a.q.storage_bytes) / 1024.0 - line.kb_per_gaussian * a.q.gaussians;
      }
  return line;
}

// The trained HAHA avatar is also a point of the pruning curve (its lowest thresholds):
// labelled there, not twice.
struct HahaPoint {
  const StageRow* row = nullptr;  // the stage table's "HAHA filtered"
  // "= HAHA as trained" goes on the re-run point at the run's own weight when there is
  // one, else on the pruning point at the trainer's threshold.
  bool on_rerun = false;
  bool shown = false;  // a filtering point carries the label
  bool is(const FilterPoint& fp) const {
    return row && fp.q.gaussians == row->q.gaussians && fp.q.psnr == row->q.psnr;
  }
};

// One filtering method's curve; empty x when the method has no point.
PlotSeries filter_method_series(const BenchResult& r, const char* method, bool psnr, HahaPoint& haha) {
  const bool prune = std::string(method) == "prune threshold";
  std::vector<const FilterPoint*> pts;
  for (const FilterPoint& fp : r.filtering)
    if (fp.method == method) pts.push_back(&fp);
  PlotSeries se;
  if (pts.empty()) return se;
  std::sort(pts.begin(), pts.end(), [](const FilterPoint* a, const FilterPoint* b) {
    return a->q.gaussians != b->q.gaussians ? a->q.gaussians < b->q.gaussians : a->strength < b->strength;
  });
  se.label = prune ? "pruning the trained opacities (labels: threshold)"
                   : std::string("stage 3 re-run (labels: ") + method + ")";
  se.labels_below = !prune;  // the curves meet at the trained avatar: labels apart
  // Points that coincide (same count and score) become one point labelled with the
  // range of settings that produce it.
  for (size_t i = 0; i < pts.size();) {
    size_t k = i;
    double lo = pts[i]->strength, hi = lo;
    while (k + 1 < pts.size() && pts[k + 1]->q.gaussians == pts[i]->q.gaussians && pts[k + 1]->q.psnr == pts[i]->q.psnr) {
      ++k;
      lo = std::min(lo, pts[k]->strength);
      hi = std::max(hi, pts[k]->strength);
    }
    se.x.push_back(pts[i]->q.gaussians);
    se.y.push_back(psnr ? pts[i]->q.psnr : pts[i]->q.ssim);
    std::string label = short_num(lo) + (hi > lo ? ".." + short_num(hi) : std::string());
    if (haha.is(*pts[i])) {
      if (prune == haha.on_rerun)
        label.clear();  // the re-run point on top of it carries the label
      else
        label += " (= HAHA as trained)";
      haha.shown = true;
    }
    se.point_labels.push_back(label);
    i = k + 1;
  }
  return se;
}

// The stage table's variants: points, and a level across the plot for those without Gaussians.
void add_stage_series(const BenchResult& r, bool psnr, const HahaPoint& haha, PlotSpec& p) {
  PlotSeries ref;
  ref.label = "trained variants (stage table)";
  ref.lines = false;
  for (const StageRow& s : r.stages) {
    if (haha.shown && &s == haha.row) continue;
    if (s.q.gaussians == 0) {  // no Gaussians: a level across the plot
      PlotSeries mesh;
      mesh.label = s.name + " (no Gaussians)";
      mesh.x = {p.xmin, p.xmax};
      const double v = psnr ? s.q.psnr : s.q.ssim;
      mesh.y = {v, v};
      mesh.right_axis = false;
      mesh.dashed = true;
      p.series.push_back(mesh);
      continue;
    }
    ref.x.push_back(s.q.gaussians);
    ref.y.push_back(psnr ? s.q.psnr : s.q.ssim);
    ref.point_labels.push_back(s.name);
  }
  if (!ref.x.empty()) p.series.push_back(ref);
}

PlotSpec filter_budget_plot(const BenchResult& r, const std::string& sub, bool psnr, const StorageLine& line) {
  // Log count axis: the knee sits at a few thousand of tens of thousands. Storage is
  // linear in the count; its formula goes in the axis label (gnuplot cannot link a
  // second axis to a log axis).
  PlotSpec p = plot_spec(std::string("Gaussian budget against error (") + (psnr ? "PSNR" : "SSIM") + " on novel poses)",
                         sub, "Gaussians kept (count, log scale)",
                         psnr ? "PSNR on test frames (dB)" : "SSIM on test frames (1 = identical)", "top left");
  if (line.kb_per_gaussian > 0)
    p.xlabel += f("; storage = %.0f KB texture", line.kb_offset) +
                f(" + %.3f KB per Gaussian (float32)", line.kb_per_gaussian);
  p.logx = true;
  double xlo = INFINITY, xhi = 0;
  for (const FilterPoint& fp : r.filtering)
    if (fp.q.gaussians > 0) xlo = std::min(xlo, double(fp.q.gaussians)), xhi = std::max(xhi, double(fp.q.gaussians));
  for (const StageRow& s : r.stages)
    if (s.q.gaussians > 0) xlo = std::min(xlo, double(s.q.gaussians)), xhi = std::max(xhi, double(s.q.gaussians));
  if (xhi > 0) p.xmin = xlo / 1.6, p.xmax = xhi * 3.0;  // room for labels on the right
  HahaPoint haha;
  for (const StageRow& s : r.stages)
    if (s.name == "HAHA filtered") haha.row = &s;
  for (const FilterPoint& fp : r.filtering)
    if (fp.method != "prune threshold" && haha.is(fp)) haha.on_rerun = true;
  for (const char* method : {"prune threshold", "opacity weight", "image cost"}) {
    PlotSeries se = filter_method_series(r, method, psnr, haha);
    if (!se.x.empty()) p.series.push_back(std::move(se));
  }
  if (!r.stages.empty()) add_stage_series(r, psnr, haha, p);
  return p;
}

// 1: Gaussian budget against error, PSNR and SSIM, with the storage in the x label.
void add_filter_plots(const BenchResult& r, const std::string& sub, Plots& plots) {
  if (r.filtering.empty()) return;
  const StorageLine line = storage_line(r.filtering);
  for (int metric = 0; metric < 2; ++metric) {
    const bool psnr = metric == 0;
    plots.emplace_back(psnr ? "filter_budget.png" : "filter_budget_ssim.png", filter_budget_plot(r, sub, psnr, line));
  }
}

// A texture point's label: its size, or the trained size named in the default setting
// ("jpg q95 256px (default)").
std::string texture_point_label(const PackPoint& pp) {
  const bool is_default = pp.setting.name.find("(default)") != std::string::npos;
  std::string label;
  if (pp.setting.texture_size > 0) {
    label = std::to_string(pp.setting.texture_size) + " px";
  } else if (is_default) {
    const size_t px = pp.setting.name.find("px");
    const size_t sp = pp.setting.name.rfind(' ', px);
    label = (px != std::string::npos && sp != std::string::npos ? pp.setting.name.substr(sp + 1, px - sp - 1) + " px, "
                                                                 : std::string()) + "default";
  }
  return label;
}

PlotSpec pack_size_plot(const BenchResult& r, const std::string& sub) {
  PlotSpec p = plot_spec("Packing against error: .glb size vs. fidelity to the original", sub, "avatar file size (KB)",
                         "PSNR of unpacked renders vs. original renders (dB)", "bottom right");
  // One series per texture codec / quality (sizes joined, labelled), one for the bits.
  PlotSeries bits;
  bits.label = "Gaussian attributes at N bits (texture png)";
  std::map<std::string, PlotSeries> tex;
  std::vector<std::string> tex_order;
  for (const PackPoint& pp : r.packing) {
    // The lossless reference (infinite or capped PSNR) is in the table, not the plot.
    if (pp.identical || pp.setting.group == "reference") continue;
    const double kbytes = double(pp.bytes.total) / 1024.0;
    if (pp.setting.group == "gaussian bits") {
      bits.x.push_back(kbytes);
      bits.y.push_back(pp.psnr_vs_original);
      bits.point_labels.push_back(std::to_string(pp.setting.gaussian_bits) + " bit");
      continue;
    }
    if (pp.setting.group != "texture") {  // mesh storage, allocation and corrective points: one series per group
      if (!tex.count(pp.setting.group)) tex_order.push_back(pp.setting.group);
      PlotSeries& s = tex[pp.setting.group];
      s.label = pp.setting.group;
      s.x.push_back(kbytes);
      s.y.push_back(pp.psnr_vs_original);
      s.point_labels.push_back(pp.setting.name);
      continue;
    }
    const std::string codec = pp.setting.texture_codec == "png"
                                  ? std::string("png")
                                  : pp.setting.texture_codec + " quality " + std::to_string(pp.setting.texture_quality);
    if (!tex.count(codec)) tex_order.push_back(codec);
    PlotSeries& s = tex[codec];
    s.label = "texture " + codec + " (Gaussians at default bits)";
    s.x.push_back(kbytes);
    s.y.push_back(pp.psnr_vs_original);
    s.point_labels.push_back(texture_point_label(pp));
  }
  if (!bits.x.empty()) p.series.push_back(bits);
  for (const std::string& c : tex_order) {
    PlotSeries& s = tex[c];
    s.lines = s.x.size() > 1;
    s.labels_below = true;  // the bit labels sit above their points
    bool any = false;
    for (const std::string& l : s.point_labels) any |= !l.empty();
    if (!any) s.point_labels.clear();
    if (s.x.size() > 1 && s.label.rfind("texture ", 0) == 0) s.label = "texture " + c + " at N px (Gaussians at default bits)";
    p.series.push_back(s);
  }
  return p;
}

PlotSpec pack_time_plot(const BenchResult& r, const std::string& sub) {
  PlotSpec d = plot_spec("Packing and decoding time per setting", sub, "pack setting", "time (ms)", "top right");
  d.height = 680;
  d.xtic_rotate = 35;
  PlotSeries dec, pk;
  dec.label = "decode: .glb bytes -> avatar (fastest of 3)";
  pk.label = "pack: avatar -> .glb bytes (one run)";
  for (size_t i = 0; i < r.packing.size(); ++i) {
    d.xcategories.push_back(r.packing[i].setting.name);
    dec.x.push_back(double(i));
    dec.y.push_back(r.packing[i].decode_ms);
    pk.x.push_back(double(i));
    pk.y.push_back(r.packing[i].pack_ms);
  }
  dec.lines = pk.lines = false;
  d.series = {dec, pk};
  return d;
}

// 2: packing against error.
void add_pack_plots(const BenchResult& r, const std::string& sub, Plots& plots) {
  if (r.packing.empty()) return;
  const PlotSpec p = pack_size_plot(r, sub);
  if (!p.series.empty()) plots.emplace_back("pack_size_error.png", p);
  plots.emplace_back("pack_time.png", pack_time_plot(r, sub));
}

std::string render_device(const RenderTiming& t) {
  return t.device == "cpu" ? "CPU " + std::to_string(t.threads) + " thread" + (t.threads == 1 ? "" : "s")
                           : std::string("GPU");
}

void add_render_resolution_plot(const BenchResult& r, const std::string& sub, Plots& plots) {
  PlotSpec p = plot_spec("Render time against resolution", sub, "image side (pixels, square image; log scale)",
                         "time per frame, LBS + render (ms, median; log scale)", "top left");
  p.logx = p.logy = true;
  std::map<std::string, PlotSeries> series;
  std::set<int> resolutions;
  for (const RenderTiming& t : r.render) {
    if (t.sweep != "resolution") continue;
    resolutions.insert(t.resolution);
    const std::string what = t.gaussians == 0 ? "mesh only" : std::to_string(t.gaussians) + " Gaussians + mesh";
    const std::string dev = render_device(t);
    PlotSeries& s = series[dev + ", " + what];
    s.label = dev + ", " + what;
    s.x.push_back(t.resolution);
    s.y.push_back(t.ms_median);
  }
  for (auto& [k, s] : series) p.series.push_back(s);
  if (!resolutions.empty()) {
    p.xmin = *resolutions.begin() / 1.25;
    p.xmax = *resolutions.rbegin() * 1.25;
    p.xtics.assign(resolutions.begin(), resolutions.end());
  }
  if (resolutions.size() > 1 && !p.series.empty()) plots.emplace_back("render_resolution.png", p);
}

void add_render_count_plot(const BenchResult& r, const std::string& sub, Plots& plots) {
  int best_res = 0;
  size_t best_n = 0;
  for (const RenderTiming& t : r.render)
    if (t.sweep == "gaussians") best_res = t.resolution, ++best_n;
  PlotSpec c = plot_spec("Render time against Gaussian count (" + std::to_string(best_res) + " x " +
                             std::to_string(best_res) + " px, with the mesh)",
                         sub, "Gaussians rendered (count)", "time per frame, LBS + render (ms, median)", "top left");
  std::map<std::string, PlotSeries> cs;
  for (const RenderTiming& t : r.render) {
    if (t.sweep != "gaussians") continue;
    const std::string dev = render_device(t);
    PlotSeries& s = cs[dev];
    s.label = dev;
    s.x.push_back(t.gaussians);
    s.y.push_back(t.ms_median);
  }
  for (auto& [k, s] : cs) {
    std::vector<size_t> idx(s.x.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    const std::vector<double>& xs = s.x;  // clang 14 cannot capture a structured binding
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return xs[a] < xs[b]; });
    PlotSeries t = s;
    for (size_t i = 0; i < idx.size(); ++i) t.x[i] = s.x[idx[i]], t.y[i] = s.y[idx[i]];
    c.series.push_back(t);
  }
  if (best_n > 1) plots.emplace_back("render_gaussians.png", c);
}

// 4: training time against quality.
PlotSpec training_quality_plot(const BenchResult& r, const std::string& sub) {
  PlotSpec p = plot_spec("Training time against quality (the trainer's stage table)", sub,
                         "training wall time needed for the variant (s)", "PSNR on test frames (dB)", "bottom right");
  p.y2label = "SSIM on test frames (1 = identical)";
  PlotSeries ps, ss;
  ps.label = "PSNR (left axis)";
  ss.label = "SSIM (right axis)";
  ss.right_axis = true;
  ps.lines = ss.lines = false;
  for (const StageRow& s : r.stages) {
    ps.x.push_back(s.train_seconds);
    ps.y.push_back(s.q.psnr);
    ps.point_labels.push_back(s.name);
    ss.x.push_back(s.train_seconds);
    ss.y.push_back(s.q.ssim);
  }
  p.series = {ps, ss};
  return p;
}

}  // namespace

std::string bench_date() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[64];
  std::strftime(b, sizeof b, "%Y-%m-%d %H:%M UTC", &tm);
  return b;
}

std::vector<std::pair<std::string, PlotSpec>> bench_plots(const BenchResult& r) {
  Plots plots;
  const std::string sub = subtitle(r);
  add_filter_plots(r, sub, plots);
  add_pack_plots(r, sub, plots);
  if (!r.render.empty()) {  // 3: render speed
    add_render_resolution_plot(r, sub, plots);
    add_render_count_plot(r, sub, plots);
  }
  if (!r.stages.empty()) plots.emplace_back("training_quality.png", training_quality_plot(r, sub));
  return plots;
}

std::string bench_json(const BenchResult& r, const std::vector<std::string>& plot_files) {
  ojson j;
  j["format"] = "haha-bench";
  j["version"] = 1;
  j["machine"] = {{"cpu_model", r.machine.cpu_model},
                  {"logical_cpus", r.machine.logical_cpus},
                  {"threads", r.machine.threads},
                  {"gpu", r.machine.gpu},
                  {"load_average", num(r.machine.load_average)},
                  {"omp_wait_policy", r.machine.omp_wait_policy}};
  j["run"] = r.run_dir;
  j["data"] = r.data_dir;
  j["preset"] = r.preset;
  j["device"] = r.device;
  j["date"] = r.date;
  j["eval"] = {{"frames", r.eval_frames}, {"resolution", r.eval_resolution}, {"tto_steps", r.tto_steps}};
  ojson rows = ojson::array();
  for (const StageRow& s : r.stages)
    rows.push_back({{"name", s.name},
                    {"gaussians", s.q.gaussians},
                    {"storage_bytes", s.q.storage_bytes},
                    {"psnr", num(s.q.psnr)},
                    {"ssim", num(s.q.ssim)},
                    {"render_ms", num(s.q.render_ms)},
                    {"train_seconds", num(s.train_seconds)}});
  j["training"] = {{"stage_seconds", {num(r.stage_seconds[0]), num(r.stage_seconds[1]), num(r.stage_seconds[2])}},
                   {"stage_steps", {r.stage_steps[0], r.stage_steps[1], r.stage_steps[2]}},
                   {"rows", rows}};
  ojson fl = ojson::array();
  for (const FilterPoint& p : r.filtering)
    fl.push_back({{"method", p.method},
                  {"strength", num(p.strength)},
                  {"gaussians", p.q.gaussians},
                  {"storage_bytes", p.q.storage_bytes},
                  {"psnr", num(p.q.psnr)},
                  {"ssim", num(p.q.ssim)},
                  {"render_ms", num(p.q.render_ms)},
                  {"stage3_seconds", num(p.stage3_seconds)}});
  j["filtering"] = fl;
  ojson pk = ojson::array();
  for (const PackPoint& p : r.packing)
    pk.push_back({{"name", p.setting.name},
                  {"group", p.setting.group},
                  {"lossless", p.setting.lossless},
                  {"gaussian_bits", p.setting.gaussian_bits},
                  {"gaussian_bits_spec", p.setting.gaussian_bits_spec},
                  {"mesh_bits_spec", p.setting.mesh_bits_spec},
                  {"texture_codec", p.setting.texture_codec},
                  {"texture_quality", p.setting.texture_quality},
                  {"texture_size", p.setting.texture_size},
                  {"pose_correctives", p.setting.pose_correctives},
                  {"bytes", p.bytes.total},
                  {"gaussian_bytes", p.bytes.gaussians},
                  {"texture_bytes", p.bytes.texture},
                  {"mesh_bytes", p.bytes.mesh},
                  {"pose_corrective_bytes", p.bytes.pose_correctives},
                  {"pack_ms", num(p.pack_ms)},
                  {"decode_ms", num(p.decode_ms)},
                  {"psnr_vs_original", num(p.psnr_vs_original)},
                  {"identical", p.identical},
                  {"psnr", num(p.psnr)},
                  {"ssim", num(p.ssim)},
                  {"psnr_cost", num(p.psnr_cost)}});
  j["packing"] = pk;
  ojson rd = ojson::array();
  for (const RenderTiming& t : r.render)
    rd.push_back({{"sweep", t.sweep},
                  {"device", t.device},
                  {"threads", t.threads},
                  {"resolution", t.resolution},
                  {"gaussians", t.gaussians},
                  {"mesh", t.mesh},
                  {"ms_median", num(t.ms_median)},
                  {"ms_min", num(t.ms_min)},
                  {"repeats", t.repeats}});
  j["render"] = rd;
  ojson sec = ojson::object();
  for (const auto& [k, v] : r.seconds) sec[k] = num(v);
  j["seconds"] = sec;
  j["plots"] = plot_files;
  j["notes"] = r.notes;
  return j.dump(2) + "\n";
}

std::string bench_markdown(const BenchResult& r, const std::vector<std::string>& plot_files) {
  std::string m = "# haha bench\n\n";
  m += "- machine: " + r.machine.line() + " (" + std::to_string(r.machine.threads) + " OpenMP threads by default, " +
       "OMP_WAIT_POLICY " + (r.machine.omp_wait_policy.empty() ? std::string("default") : r.machine.omp_wait_policy) +
       (r.machine.load_average >= 0 ? f(", load average %.2f at the start", r.machine.load_average) : std::string()) + ")\n";
  m += "- run: `" + r.run_dir + "` (preset " + r.preset + "), data: `" + r.data_dir + "`\n";
  m += "- quality measured on " + std::to_string(r.eval_frames) + " test frames (novel poses) at " +
       std::to_string(r.eval_resolution) + " px, black background, test-time pose optimisation " +
       (r.tto_steps > 0 ? std::to_string(r.tto_steps) + " steps" : std::string("off")) + "\n";
  m += "- date: " + r.date + ", device: " + r.device + "\n";
  double total = 0;
  for (const auto& [k, v] : r.seconds) total += v;
  m += "- bench wall time: " + f("%.1f s", total) + " (";
  bool first = true;
  for (const auto& [k, v] : r.seconds) m += (first ? "" : ", ") + k + " " + f("%.1f s", v), first = false;
  m += ")\n\n";
  auto has_plot = [&](const std::string& name) {
    for (const std::string& p : plot_files)
      if (std::filesystem::path(p).filename() == name) return true;
    return false;
  };
  auto img = [&](const std::string& name, const std::string& alt) {
    if (has_plot(name)) m += "![" + alt + "](plots/" + name + ")\n\n";
  };

  if (!r.stages.empty()) {
    m += "## Training time against quality\n\n";
    m += "| stage | steps | wall time (s) |\n|---|---:|---:|\n";
    const char* names[3] = {"1 Gaussians", "2 texture", "3 filtering"};
    for (int i = 0; i < 3; ++i)
      m += std::string("| ") + names[i] + " | " + std::to_string(r.stage_steps[size_t(i)]) + " | " +
           f("%.1f", r.stage_seconds[size_t(i)]) + " |\n";
    m += "\n| variant | Gaussians | storage (KB) | PSNR (dB) | SSIM | render (ms) | training time (s) |\n";
    m += "|---|---:|---:|---:|---:|---:|---:|\n";
    for (const StageRow& s : r.stages)
      m += "| " + s.name + " | " + std::to_string(s.q.gaussians) + " | " + kb(double(s.q.storage_bytes)) + " | " +
           f("%.2f", s.q.psnr) + " | " + f("%.4f", s.q.ssim) + " | " + f("%.1f", s.q.render_ms) + " | " +
           f("%.1f", s.train_seconds) + " |\n";
    m += "\nTraining time per variant as the paper attributes it: mesh only = stage 2, full Gaussians = "
         "stage 1, naive merge = stages 1 + 2, HAHA = all three.\n\n";
    img("training_quality.png", "training time against quality");
  }

  if (!r.filtering.empty()) {
    m += "## Gaussian budget against error\n\n";
    img("filter_budget.png", "Gaussian budget against error");
    img("filter_budget_ssim.png", "Gaussian budget against SSIM");
    m += "| method | strength | Gaussians | storage (KB) | PSNR (dB) | SSIM | render (ms) | stage 3 (s) |\n";
    m += "|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const FilterPoint& p : r.filtering)
      m += "| " + p.method + " | " + short_num(p.strength) + " | " + std::to_string(p.q.gaussians) + " | " +
           kb(double(p.q.storage_bytes)) + " | " + f("%.2f", p.q.psnr) + " | " + f("%.4f", p.q.ssim) + " | " +
           f("%.1f", p.q.render_ms) + " | " + (p.stage3_seconds > 0 ? f("%.1f", p.stage3_seconds) : std::string("-")) +
           " |\n";
    // Where the curve bends: the fewest Gaussians within 0.1 / 0.5 dB of the best PSNR.
    double best = -INFINITY;
    for (const FilterPoint& p : r.filtering)
      if (std::isfinite(p.q.psnr)) best = std::max(best, p.q.psnr);
    for (double tol : {0.1, 0.5}) {
      const FilterPoint* knee = nullptr;
      for (const FilterPoint& p : r.filtering)
        if (p.q.psnr >= best - tol && (!knee || p.q.gaussians < knee->q.gaussians)) knee = &p;
      if (knee)
        m += "\n- " + std::to_string(knee->q.gaussians) + " Gaussians (" + knee->method + " " + short_num(knee->strength) +
             ", " + kb(double(knee->q.storage_bytes)) + " KB) stay within " + short_num(tol) +
             " dB of the best PSNR measured (" + f("%.2f dB", best) + ").";
    }
    m += "\n";
  }

  if (!r.packing.empty()) {
    m += "## Packing against error\n\n";
    img("pack_size_error.png", "file size against PSNR vs the original");
    img("pack_time.png", "pack and decode time");
    m += "| setting | file (KB) | Gaussians (KB) | texture (KB) | mesh (KB) | correctives (KB) | PSNR vs original (dB) | PSNR cost vs truth (dB) | pack (ms) | decode (ms) |\n";
    m += "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const PackPoint& p : r.packing)
      m += "| " + p.setting.name + " | " + kb(double(p.bytes.total)) + " | " + kb(double(p.bytes.gaussians)) + " | " +
           kb(double(p.bytes.texture)) + " | " + kb(double(p.bytes.mesh)) + " | " + kb(double(p.bytes.pose_correctives)) + " | " +
           (p.identical ? std::string("identical")
                        : p.psnr_vs_original >= kPsnrCap ? ">= " + short_num(kPsnrCap)
                                                         : f("%.2f", p.psnr_vs_original)) +
           " | " + f("%.3f", p.psnr_cost) +
           " | " + f("%.1f", p.pack_ms) + " | " + f("%.1f", p.decode_ms) + " |\n";
    m += "\n";
  }

  if (!r.render.empty()) {
    m += "## Render speed\n\n";
    img("render_resolution.png", "render time against resolution");
    img("render_gaussians.png", "render time against Gaussian count");
    m += "| device | threads | image side (px) | Gaussians | mesh | median (ms) | min (ms) | frames/s |\n";
    m += "|---|---:|---:|---:|---|---:|---:|---:|\n";
    for (const RenderTiming& t : r.render)
      m += "| " + t.device + " | " + (t.device == "cpu" ? std::to_string(t.threads) : std::string("-")) + " | " +
           std::to_string(t.resolution) + " | " + std::to_string(t.gaussians) + " | " + (t.mesh ? "yes" : "no") + " | " +
           f("%.2f", t.ms_median) + " | " + f("%.2f", t.ms_min) + " | " +
           (t.ms_median > 0 ? f("%.1f", 1000.0 / t.ms_median) : std::string("-")) + " |\n";
    m += "\n";
  }

  if (!r.notes.empty()) {
    m += "## How these were measured\n\n";
    for (const std::string& n : r.notes) m += "- " + n + "\n";
  }
  return m;
}

BenchResult read_bench_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  ojson j;
  try {
    j = ojson::parse(in);
  } catch (const std::exception& e) {
    fail(path, std::string("not JSON: ") + e.what());
  }
  // null (a non-finite measurement when written) reads back as NaN.
  auto d = [](const ojson& v) { return v.is_null() ? double(NAN) : v.get<double>(); };
  BenchResult r;
  try {
    if (j.at("format") != "haha-bench") fail(path, "format: not a haha bench file");
    const ojson& m = j.at("machine");
    r.machine.cpu_model = m.at("cpu_model");
    r.machine.logical_cpus = m.at("logical_cpus");
    r.machine.threads = m.at("threads");
    r.machine.gpu = m.at("gpu");
    r.machine.load_average = m.contains("load_average") ? d(m.at("load_average")) : -1.0;
    r.machine.omp_wait_policy = m.value("omp_wait_policy", std::string());
    if (!(r.machine.load_average >= 0)) r.machine.load_average = -1;
    r.run_dir = j.at("run");
    r.data_dir = j.at("data");
    r.preset = j.at("preset");
    r.device = j.at("device");
    r.date = j.at("date");
    r.eval_frames = j.at("eval").at("frames");
    r.eval_resolution = j.at("eval").at("resolution");
    r.tto_steps = j.at("eval").at("tto_steps");
    const ojson& t = j.at("training");
    for (int i = 0; i < 3; ++i) {
      r.stage_seconds[size_t(i)] = d(t.at("stage_seconds").at(size_t(i)));
      r.stage_steps[size_t(i)] = t.at("stage_steps").at(size_t(i));
    }
    auto quality = [&](const ojson& x) {
      QualityPoint q;
      q.gaussians = x.at("gaussians");
      q.storage_bytes = x.at("storage_bytes");
      q.psnr = d(x.at("psnr"));
      q.ssim = d(x.at("ssim"));
      q.render_ms = d(x.at("render_ms"));
      return q;
    };
    for (const ojson& x : t.at("rows")) {
      StageRow row;
      row.name = x.at("name");
      row.q = quality(x);
      row.train_seconds = d(x.at("train_seconds"));
      r.stages.push_back(row);
    }
    for (const ojson& x : j.at("filtering")) {
      FilterPoint p;
      p.method = x.at("method");
      p.strength = d(x.at("strength"));
      p.q = quality(x);
      p.stage3_seconds = d(x.at("stage3_seconds"));
      r.filtering.push_back(p);
    }
    for (const ojson& x : j.at("packing")) {
      PackPoint p;
      p.setting.name = x.at("name");
      p.setting.group = x.at("group");
      p.setting.lossless = x.at("lossless");
      p.setting.gaussian_bits = x.at("gaussian_bits");
      p.setting.gaussian_bits_spec = x.value("gaussian_bits_spec", std::string());
      p.setting.mesh_bits_spec = x.value("mesh_bits_spec", std::string());
      p.setting.texture_codec = x.at("texture_codec");
      p.setting.texture_quality = x.at("texture_quality");
      p.setting.texture_size = x.at("texture_size");
      p.setting.pose_correctives = x.value("pose_correctives", std::string());
      p.bytes.total = x.at("bytes");
      p.bytes.gaussians = x.at("gaussian_bytes");
      p.bytes.texture = x.at("texture_bytes");
      p.bytes.mesh = x.at("mesh_bytes");
      p.bytes.pose_correctives = x.value("pose_corrective_bytes", size_t(0));
      p.pack_ms = d(x.at("pack_ms"));
      p.decode_ms = d(x.at("decode_ms"));
      p.psnr_vs_original = d(x.at("psnr_vs_original"));
      p.identical = x.at("identical");
      p.psnr = d(x.at("psnr"));
      p.ssim = d(x.at("ssim"));
      p.psnr_cost = d(x.at("psnr_cost"));
      r.packing.push_back(p);
    }
    for (const ojson& x : j.at("render")) {
      RenderTiming rt;
      rt.sweep = x.at("sweep");
      rt.device = x.at("device");
      rt.threads = x.at("threads");
      rt.resolution = x.at("resolution");
      rt.gaussians = x.at("gaussians");
      rt.mesh = x.at("mesh");
      rt.ms_median = d(x.at("ms_median"));
      rt.ms_min = d(x.at("ms_min"));
      rt.repeats = x.at("repeats");
      r.render.push_back(rt);
    }
    for (const auto& [k, v] : j.at("seconds").items()) r.seconds[k] = d(v);
    for (const ojson& n : j.at("notes")) r.notes.push_back(n);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(path, std::string("malformed bench file: ") + e.what());
  }
  return r;
}

std::vector<std::string> write_bench_report(const std::string& out_dir, const BenchResult& r) {
  namespace fs = std::filesystem;
  ensure_directory(out_dir);
  const std::vector<std::pair<std::string, PlotSpec>> plots = bench_plots(r);
  std::vector<std::string> names, paths;
  for (const auto& [name, spec] : plots) names.push_back("plots/" + name);
  // Numbers first: a missing gnuplot must not lose the measurements.
  write_text_file((fs::path(out_dir) / "bench.json").string(), bench_json(r, names));
  write_text_file((fs::path(out_dir) / "bench.md").string(), bench_markdown(r, names));
  ensure_directory((fs::path(out_dir) / "plots").string());
  for (const auto& [name, spec] : plots) {
    const std::string path = (fs::path(out_dir) / "plots" / name).string();
    write_plot_png(path, spec);
    paths.push_back(path);
  }
  return paths;
}

}  // namespace haha
