#include "app/fit_video_run.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>

#include "fit/fit_video_crop.h"
#include "fit/fit_video_focal.h"
#include "app/fit_video_input.h"
#include "fit/fit_video_truth.h"
#include "app/keypoint_tool.h"
#include "body/lbs.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "data/background_matting.h"
#include "data/contact_sheet.h"
#include "data/dataset.h"
#include "data/stage_dir.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/keypoints_json.h"
#include "train/config.h"

namespace haha {

namespace fs = std::filesystem;

namespace {

// The fitter's result must describe exactly the frames it was given.
void check_fit_result(const FitVideoResult& r, int n, int width, int height) {
  const std::string where = "fit-video: the fit";
  if (int(r.report.size()) != n)
    fail(where, "reported " + std::to_string(r.report.size()) + " frames for " + std::to_string(n) + " given");
  if (r.params.size() != r.kept.size())
    fail(where, std::to_string(r.params.size()) + " parameter sets for " + std::to_string(r.kept.size()) + " kept frames");
  for (size_t k = 0; k < r.kept.size(); ++k) {
    const int i = r.kept[k];
    if (i < 0 || i >= n || (k > 0 && i <= r.kept[k - 1])) fail(where, "kept frame indices are not increasing in [0, n)");
    if (r.report[size_t(i)].dropped) fail(where, "frame " + std::to_string(i) + " is both kept and dropped");
  }
  int kept_in_report = 0;
  for (const FitVideoFrameReport& f : r.report) kept_in_report += !f.dropped;
  if (kept_in_report != int(r.kept.size()))
    fail(where, "the report keeps " + std::to_string(kept_in_report) + " frames, the result " + std::to_string(r.kept.size()));
  if (!r.kept.empty() && (r.camera.width != width || r.camera.height != height))
    fail(where, "camera is " + std::to_string(r.camera.width) + "x" + std::to_string(r.camera.height) +
                    ", the frames are " + std::to_string(width) + "x" + std::to_string(height));
}

// A frame as RGB (the work frames are RGB PNGs; a grey or RGBA one is taken as it comes).
Image frame_rgb(const std::string& path) { return to_rgb(read_image(path), path); }

// The plate keeps 8-bit copies of its frames (4 bytes a pixel): at most this many bytes,
// the frames spread evenly over the video beyond it (about 100 frames of 1280x720).
constexpr double kPlateBytes = 384e6;

// The background plate from the frames given to the fit (kept or not: a frame the person
// left is the best one), spread evenly when there are more than the budget holds.
BackgroundPlate make_plate(const InputFrames& in, const std::vector<FitVideoInputFrame>& frames,
                           const MattingOptions& mo) {
  const int n = int(in.paths.size());
  const int most = std::max(8, int(kPlateBytes / (4.0 * in.width * in.height)));
  const int use = std::min(n, most);
  BackgroundPlateBuilder b(in.width, in.height, mo);
  b.reserve(use);
  for (int k = 0; k < use; ++k) {
    check_interrupted();
    const int i = int((int64_t(k) * n) / use);
    b.add(frame_rgb(in.paths[size_t(i)]), frames[size_t(i)].mask);
  }
  return b.build();
}

using SayFn = std::function<void(const std::string&)>;

// The focal length: a flag, else what the video or the first image records, else a guess.
FocalChoice run_focal(const FitVideoRunOptions& opt, const InputFrames& in) {
  const int n = int(in.paths.size());
  RecordedFocal recorded;  // read only when nothing given beats it
  if (opt.focal_px <= 0 && opt.focal_35mm <= 0 && !opt.fov_given && n > 0)
    recorded = in.is_video ? video_recorded_focal(opt.input)
                           : image_recorded_focal((fs::path(opt.input) / in.names[0]).string());
  return choose_focal(opt.focal_px, opt.focal_35mm, opt.fov_deg, opt.fov_given, recorded, in.width, in.height);
}

// What the keypoint tool wrote into `kp_dir` for each frame: keypoints, and a mask when it made one.
std::vector<FitVideoInputFrame> read_tool_frames(const InputFrames& in, const fs::path& kp_dir) {
  const int n = int(in.paths.size());
  std::error_code ec;
  std::vector<FitVideoInputFrame> frames(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    check_interrupted();
    const std::string stem = fs::path(in.paths[size_t(i)]).stem().string();
    const std::string json = (kp_dir / "keypoints" / (stem + ".json")).string();
    if (!fs::is_regular_file(json, ec)) fail(json, "missing: the keypoint tool wrote no file for " + in.paths[size_t(i)]);
    FitVideoInputFrame& f = frames[size_t(i)];
    f.keypoints = read_keypoints_json(json);
    if (f.keypoints.width != in.width || f.keypoints.height != in.height)
      fail(json, "size " + std::to_string(f.keypoints.width) + "x" + std::to_string(f.keypoints.height) +
                     " differs from the frame's " + std::to_string(in.width) + "x" + std::to_string(in.height));
    if (!f.keypoints.mask.empty()) {
      const std::string mpath = (kp_dir / f.keypoints.mask).string();
      f.mask = read_image(mpath);
      if (f.mask.width != in.width || f.mask.height != in.height || f.mask.channels != 1)
        fail(mpath, "mask is " + std::to_string(f.mask.width) + "x" + std::to_string(f.mask.height) + "x" +
                        std::to_string(f.mask.channels) + ", expected " + std::to_string(in.width) + "x" +
                        std::to_string(in.height) + " with one channel");
    }
  }
  return frames;
}

// The summary's input and one row per frame given to the fit, kept or dropped.
FitVideoSummary start_summary(const FitVideoRunOptions& opt, const std::string& out, const InputFrames& in,
                              const FrameRange& range, const FocalChoice& focal, const FitVideoResult& r) {
  const int n = int(in.paths.size());
  FitVideoSummary s;
  s.input = opt.input;
  s.out = out;
  s.decoded = in.decoded;
  s.width = in.width;
  s.height = in.height;
  s.fps = in.fps / range.step;
  s.camera = r.camera;
  s.focal_source = focal.source;
  s.frames.resize(size_t(n));
  for (int i = 0; i < n; ++i) {
    FitVideoFrameRow& row = s.frames[size_t(i)];
    const FitVideoFrameReport& rep = r.report[size_t(i)];
    row.name = in.names[size_t(i)];
    row.source_index = in.source_index[size_t(i)];
    row.dropped = rep.dropped;
    row.reason = rep.dropped && rep.reason.empty() ? std::string("dropped by the fit") : rep.reason;
    row.reprojection_px = rep.reprojection_px;
    row.silhouette_iou = rep.silhouette_iou;
  }
  return s;
}

// Matting against the background plate, when the camera stands still: the plate, or an
// empty one when matting is off or the camera moved.
BackgroundPlate matting_plate(const FitVideoRunOptions& opt, const InputFrames& in,
                              const std::vector<FitVideoInputFrame>& frames, const MattingOptions& mo,
                              FitVideoSummary& s, const SayFn& say) {
  BackgroundPlate plate;
  s.matting = opt.matting;
  if (opt.matting == "off") return plate;
  say("[4/4] background plate");
  plate = make_plate(in, frames, mo);
  s.plate_frames = plate.frames;
  s.plate_candidates = int(in.paths.size());
  s.plate_hole_share = plate.hole_share;
  s.plate_filled_share = plate.filled_share;
  s.background_residual = plate.residual;
  s.static_threshold = mo.static_threshold;
  s.matting_used = plate.camera_static(mo);
  if (!s.matting_used) plate = BackgroundPlate{};
  say("[4/4] " + matting_report_line(s));
  return plate;
}

// The person's box over the kept frames: their masks and the fitted body.
CropBox person_box(const BodyModel& body, const FitVideoResult& r, const std::vector<FitVideoInputFrame>& frames) {
  CropBox person;
  Lbs<float> lbs(body);
  std::vector<float> verts(size_t(body.num_verts) * 3), joints(size_t(kNumJoints) * 3);
  for (size_t k = 0; k < r.kept.size(); ++k) {
    const FitVideoInputFrame& f = frames[size_t(r.kept[k])];
    if (!f.mask.empty()) person = box_union(person, mask_box(f.mask));
    if (body.num_verts > 0) {
      lbs.forward(r.params[k], verts.data(), joints.data(), nullptr);
      person = box_union(person, projected_box(r.camera, verts.data(), body.num_verts));
    }
  }
  return person;
}

// The dataset's crop: the person's box with a margin (or the whole frame), into the summary.
CropBox choose_crop(const FitVideoRunOptions& opt, const CropBox& person, const InputFrames& in, FitVideoSummary& s) {
  const CropBox box = opt.crop ? dataset_crop(person, in.width, in.height) : CropBox{0, 0, in.width, in.height};
  s.cropped = opt.crop;  // a person filling the frame is "cropped" to the whole frame
  s.crop_x0 = box.x0;
  s.crop_y0 = box.y0;
  s.crop_w = box.w;
  s.crop_h = box.h;
  s.person_height_px = person.h;
  s.train_resolution = train_resolution(make_preset("standard"), std::max(box.w, box.h));
  return box;
}

// What the dataset is made of: the input frames, the tool's masks, the fit, the plate and the crop.
struct DatasetParts {
  const InputFrames& in;
  const std::vector<FitVideoInputFrame>& frames;
  const FitVideoResult& r;
  const BackgroundPlate& plate;
  const MattingOptions& mo;
  const CropBox& box;
};

// The kept frames into the dataset staged at `stage`, each row given its dataset frame and split.
void write_fit_dataset(const FitVideoRunOptions& opt, const DatasetParts& d, const fs::path& stage, FitVideoSummary& s) {
  const int n = int(d.in.paths.size());
  const std::string source = "haha fit-video: " + fs::path(opt.input).filename().string() + " (" +
                             std::to_string(d.r.kept.size()) + " of " + std::to_string(n) + " frames kept)";
  const Camera dataset_camera = crop_camera(d.r.camera, d.box);
  DatasetWriter writer(stage.string(), d.box.w, d.box.h, s.fps, "neutral", source);
  // Matted frames are alpha x colour on black; else camera frames with the tool's masks.
  writer.set_premultiplied(s.matting_used ? 1 : 0);
  writer.set_fits(Fits::estimated);  // fitted to keypoints: haha train picks the settings for estimated fits
  if (s.cropped) writer.set_source_crop(d.box.x0, d.box.y0, d.box.w, d.box.h);
  double band = 0, band_known = 0, band_filled = 0;  // the edge band's share of the frames, where the plate
                                                     // knew it, where that was a filled hole
  for (size_t k = 0; k < d.r.kept.size(); ++k) {
    check_interrupted();
    const int i = d.r.kept[k];
    FitVideoFrameRow& row = s.frames[size_t(i)];
    const FitVideoInputFrame& f = d.frames[size_t(i)];
    if (f.mask.empty())
      fail(d.in.paths[size_t(i)], "the fit kept this frame but the keypoint tool gave it no mask");
    DatasetFrame df;
    df.split = fit_video_split(opt, int(k), row.source_index);
    df.camera = dataset_camera;
    df.params = d.r.params[k];
    df.source_index = row.source_index;
    df.image_path = d.in.paths[size_t(i)];
    Image rgb = frame_rgb(d.in.paths[size_t(i)]), mask = f.mask;
    if (s.matting_used) {
      Matte m = refine_matte(rgb, mask, d.plate, d.mo);
      band += m.band_share, band_known += m.band_share * m.band_known, band_filled += m.band_share * m.band_filled;
      rgb = std::move(m.premultiplied);
      mask = std::move(m.alpha);
    }
    if (s.cropped) {
      rgb = crop(rgb, d.box.x0, d.box.y0, d.box.w, d.box.h);
      mask = crop(mask, d.box.x0, d.box.y0, d.box.w, d.box.h);
    }
    writer.add(df, rgb, mask);
    row.dataset_frame = int(k);
    row.split = df.split;
    ++(df.split == Split::test ? s.test : s.train);
  }
  if (s.matting_used && band > 0) s.matted_band_share = band_known / band, s.filled_band_share = band_filled / band;
  if (s.train == 0) fail(opt.out, "every kept frame went to the test split (--test-every / --test-from): nothing to train on");
  writer.finish();
}

// With --truth: each kept frame's joint and orientation error against the true fit.
void add_truth_errors(const FitVideoTruth& truth, const BodyModel& body, const FitVideoResult& r, FitVideoSummary& s) {
  const Lbs<double> fit_lbs(body), truth_lbs(truth.body);
  for (size_t k = 0; k < r.kept.size(); ++k) {
    FitVideoFrameRow& row = s.frames[size_t(r.kept[k])];
    const size_t t = size_t(row.source_index);
    row.joint_error_mm = body_joint_pa_error_mm(fit_lbs, r.params[k], truth_lbs, truth.params[t]);
    row.orient_error_deg = body_orient_error_deg(r.camera, r.params[k], truth.cameras[t], truth.params[t]);
  }
}

// The contact sheet: the fitted body over a spread of the frames, the dropped ones marked.
void write_fit_sheet(const FitVideoRunOptions& opt, const BodyModel& body, const InputFrames& in,
                     const std::vector<FitVideoInputFrame>& frames, const FitVideoResult& r, const FitVideoSummary& s,
                     const std::string& path) {
  std::vector<ContactSheetTile> tiles;
  Lbs<float> lbs(body);
  std::vector<float> verts, joints(size_t(kNumJoints) * 3);
  for (int i : sheet_frames(s.frames, opt.sheet_tiles)) {
    check_interrupted();
    const FitVideoFrameRow& row = s.frames[size_t(i)];
    verts.clear();
    if (!row.dropped) {
      verts.resize(size_t(body.num_verts) * 3);
      lbs.forward(r.params[size_t(row.dataset_frame)], verts.data(), joints.data(), nullptr);
    }
    ContactSheetTile t;
    t.image = draw_fit_overlay(read_image(in.paths[size_t(i)]), r.camera, body, verts, frames[size_t(i)].keypoints,
                               row.dropped);
    t.label = sheet_label(row);
    tiles.push_back(std::move(t));
  }
  ContactSheetOptions co;
  co.columns = 8;
  co.max_tile = 192;
  co.title = "HAHA FIT-VIDEO: " + fs::path(opt.input).filename().string() + ", " + std::to_string(s.kept) + " KEPT, " +
             std::to_string(s.dropped) + " DROPPED (RED)";
  write_contact_sheet(path, tiles, co);
}

}  // namespace

void validate_fit_video_options(const FitVideoRunOptions& o) {
  if (o.out.empty()) fail("--out", "give the output dataset directory");
  if (!(o.fps >= 0) || !std::isfinite(o.fps) || o.fps > 1000) fail("--fps", "must be in [0, 1000] (0: every frame)");
  if (!(o.focal_px >= 0) || !std::isfinite(o.focal_px) || o.focal_px > 1e6) fail("--focal", "must be a positive number of pixels");
  if (!(o.fov_deg > 1 && o.fov_deg < 179)) fail("--fov", "must be in (1, 179) degrees");
  if (o.focal_35mm != 0 && !(o.focal_35mm >= kFocal35mmMin && o.focal_35mm <= kFocal35mmMax))
    fail("--focal-35mm", "must be a 35 mm-equivalent focal length in [" + std::to_string(int(kFocal35mmMin)) + ", " +
                             std::to_string(int(kFocal35mmMax)) + "] mm");
  if (o.focal_px > 0 && o.focal_35mm > 0) fail("--focal-35mm", "give either --focal or --focal-35mm, not both");
  if (!(o.robust_smoothness >= 0 && o.robust_smoothness <= 10))
    fail("--robust-smoothness", "must be in [0, 10] radians (0: quadratic smoothness)");
  if (o.test_every < 0 || o.test_every == 1) fail("--test-every", "must be 0 (no test frames) or >= 2");
  if (o.test_from < 0) fail("--test-from", "must be a frame number >= 1 (0: no held-out end)");
  if (o.mask != "pose" && o.mask != "selfie") fail("--mask", "'" + o.mask + "' is neither pose nor selfie");
  if (o.keypoints != "accurate" && o.keypoints != "fast")
    fail("--keypoints", "'" + o.keypoints + "' is neither accurate nor fast");
  if (o.matting != "auto" && o.matting != "off") fail("--matting", "'" + o.matting + "' is neither auto nor off");
  if (o.sheet_tiles < 1) fail("contact sheet", "needs at least one tile");
  parse_frame_range(o.frames);
  std::string out = o.out;
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  if (fs::path(out).lexically_normal() == fs::path(o.input).lexically_normal())
    fail("--out", "must not be the input");
  if (!dataset_dir_replaceable(out)) fail(out, "exists, is not empty and holds no dataset.json: refusing to replace it");
}

Split fit_video_split(const FitVideoRunOptions& o, int kept_ordinal, int source_index) {
  const bool every = o.test_every > 0 && (kept_ordinal + 1) % o.test_every == 0;
  const bool end = o.test_from > 0 && source_index >= o.test_from;
  return every || end ? Split::test : Split::train;
}

FitVideoFits fit_video_poses(const FitVideoRunOptions& opt, const SmplxFitter& fit, const std::string& work,
                             const std::function<void(const std::string&)>& say) {
  const FrameRange range = parse_frame_range(opt.frames);
  const std::string tool = find_keypoint_tool(opt.keypoint_tool);
  // (1) frames
  say("[1/4] frames from " + opt.input);
  const InputFrames in = prepare_input_frames(opt.input, work, opt.fps, range, opt.progress);
  const int n = int(in.paths.size());
  say("[1/4] " + std::to_string(n) + " frames of " + std::to_string(in.width) + "x" + std::to_string(in.height) + " (" +
      std::to_string(in.decoded) + (in.is_video ? " decoded)" : " found)"));
  const FocalChoice focal = run_focal(opt, in);
  char focal_line[64];
  std::snprintf(focal_line, sizeof focal_line, "[1/4] focal length %.1f px: ", focal.focal_px);
  say(focal_line + focal.source);

  // (2) keypoints and masks
  say("[2/4] keypoints and masks (" + tool + ")");
  const fs::path kp_dir = fs::path(work) / "keypoints";
  run_keypoint_tool(tool, (fs::path(work) / "frames").string(), kp_dir.string(), opt.mask, opt.keypoints == "fast",
                    opt.progress, (fs::path(work) / "keypoints.log").string());
  const std::vector<FitVideoInputFrame> frames = read_tool_frames(in, kp_dir);
  int with_person = 0;
  for (const FitVideoInputFrame& f : frames) with_person += f.keypoints.has_person();
  say("[2/4] a person in " + std::to_string(with_person) + " of " + std::to_string(n) + " frames");

  // (3) the fit
  say("[3/4] SMPL-X fit");
  FitVideoOptions vo;
  vo.focal_px = focal.focal_px;
  vo.weights.smooth_sigma = opt.robust_smoothness;
  vo.progress = opt.progress;
  vo.frame_interval_s = range.step / in.fps;  // the smoothness follows the time between fitted frames
  const FitVideoResult r = fit(frames, vo);
  check_fit_result(r, n, in.width, in.height);
  if (r.kept.empty()) fail(opt.input, "no frame could be fitted (see the reasons above; nothing written)");
  say("[3/4] " + std::to_string(r.kept.size()) + " frames kept, " + std::to_string(n - int(r.kept.size())) + " dropped");

  return {in, range, frames, r, focal};
}

FitVideoSummary run_fit_video(const FitVideoRunOptions& opt, const BodyModel& body, const SmplxFitter& fit) {
  const auto t0 = std::chrono::steady_clock::now();
  const SayFn say = [&](const std::string& s) {
    if (!opt.progress) return;
    std::printf("fit-video: %s (%.1f s)\n", s.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::fflush(stdout);
  };
  validate_fit_video_options(opt);
  const FrameRange range = parse_frame_range(opt.frames);
  std::string out = opt.out;
  while (out.size() > 1 && out.back() == '/') out.pop_back();

  // Cheap checks first: the input, then the tools, before anything long runs.
  check_input(opt.input);
  const std::string tool = find_keypoint_tool(opt.keypoint_tool);
  check_keypoint_tool(tool);
  FitVideoTruth truth;
  if (!opt.truth.empty()) truth = read_fit_video_truth(opt.truth, body);

  const std::string pid = std::to_string(::getpid());
  const fs::path work = out + ".fit-work-" + pid, stage = out + ".fit-" + pid;
  std::error_code ec;
  fs::remove_all(work, ec);
  fs::remove_all(stage, ec);
  DirGuard work_guard(work.string()), stage_guard(stage.string());

  const FitVideoFits fits = fit_video_poses(opt, fit, work.string(), say);
  const InputFrames& in = fits.in;
  const std::vector<FitVideoInputFrame>& frames = fits.frames;
  const FitVideoResult& r = fits.result;
  const FocalChoice& focal = fits.focal;
  const int n = int(in.paths.size());
  if (!opt.truth.empty()) check_truth_frames(truth, in.decoded);

  // (4) the dataset, the report and the contact sheet
  FitVideoSummary s = start_summary(opt, out, in, range, focal, r);
  const MattingOptions mo;
  const BackgroundPlate plate = matting_plate(opt, in, frames, mo, s, say);
  const CropBox box = choose_crop(opt, person_box(body, r, frames), in, s);
  say("[4/4] " + crop_report_line(s));
  write_fit_dataset(opt, {in, frames, r, plate, mo, box}, stage, s);
  s.kept = int(r.kept.size());
  s.dropped = n - s.kept;
  if (!opt.truth.empty()) {
    s.truth = opt.truth;
    add_truth_errors(truth, body, r, s);
  }
  summarize_fit(s);
  say("[4/4] dataset: " + std::to_string(s.train) + " train + " + std::to_string(s.test) + " test frames");

  write_text_file((stage / "fit_report.json").string(), fit_report_json(s));
  write_text_file((stage / "fit_report.txt").string(), fit_report_table(s));
  if (opt.save_body) save_body_model(body, (stage / "body_model.npz").string());
  write_fit_sheet(opt, body, in, frames, r, s, (stage / "fit_contact_sheet.png").string());

  fs::rename(work, stage / "work", ec);
  if (ec) fail((stage / "work").string(), "cannot move the work folder: " + ec.message());
  check_interrupted();  // the last chance: after this the dataset is in place
  move_dir_into_place(stage.string(), out);
  stage_guard.release();
  say("done: " + out + " (train with: haha train --data " + out + ")");
  return s;
}

}  // namespace haha
