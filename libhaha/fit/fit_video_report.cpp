#include "fit/fit_video_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "render/mesh_raster.h"

namespace haha {

using ojson = nlohmann::ordered_json;

namespace {

ojson number_or_null(double v) { return std::isfinite(v) ? ojson(v) : ojson(nullptr); }

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

void fill_square(Image& img, double cx, double cy, int half, const float rgb[3]) {
  const int x0 = int(std::floor(cx)) - half, y0 = int(std::floor(cy)) - half;
  for (int y = std::max(0, y0); y <= std::min(img.height - 1, y0 + 2 * half); ++y)
    for (int x = std::max(0, x0); x <= std::min(img.width - 1, x0 + 2 * half); ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[c];
}

void draw_segment(Image& img, const Keypoint2& a, const Keypoint2& b, int half, const float rgb[3]) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  if (!(len < 4.0 * (img.width + img.height))) return;  // non-finite or absurd
  const int steps = std::max(1, int(len));
  for (int k = 0; k <= steps; ++k) {
    const double t = double(k) / steps;
    fill_square(img, a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), half, rgb);
  }
}

// BlazePose limbs drawn as the skeleton.
constexpr int kLimbs[][2] = {{11, 12}, {11, 13}, {13, 15}, {12, 14}, {14, 16}, {11, 23}, {12, 24}, {23, 24},
                             {23, 25}, {25, 27}, {24, 26}, {26, 28}, {27, 29}, {29, 31}, {28, 30}, {30, 32}};
constexpr double kVisible = 0.5;  // visibility from which a point counts as seen

}  // namespace

void summarize_fit(FitVideoSummary& s) {
  double rp = 0, iou = 0, pa = 0, rot = 0;
  int nrp = 0, niou = 0, npa = 0, nrot = 0;
  for (const FitVideoFrameRow& r : s.frames) {
    if (r.dropped) continue;
    if (std::isfinite(r.reprojection_px)) rp += r.reprojection_px, ++nrp;
    if (std::isfinite(r.silhouette_iou)) iou += r.silhouette_iou, ++niou;
    if (std::isfinite(r.joint_error_mm)) pa += r.joint_error_mm, ++npa;
    if (std::isfinite(r.orient_error_deg)) rot += r.orient_error_deg, ++nrot;
  }
  s.mean_reprojection_px = nrp ? rp / nrp : NAN;
  s.mean_silhouette_iou = niou ? iou / niou : NAN;
  s.mean_joint_error_mm = npa ? pa / npa : NAN;
  s.mean_orient_error_deg = nrot ? rot / nrot : NAN;
}

std::string crop_report_line(const FitVideoSummary& s) {
  if (s.crop_w <= 0) return "";
  char b[512];
  const std::string frame = std::to_string(s.width) + "x" + std::to_string(s.height);
  if (s.cropped)
    std::snprintf(b, sizeof b, "crop %dx%d at (%d, %d) of the %s frames (dataset.json source_crop)", s.crop_w, s.crop_h,
                  s.crop_x0, s.crop_y0, frame.c_str());
  else
    std::snprintf(b, sizeof b, "no crop (--no-crop): the whole %s frames", frame.c_str());
  std::string out = b;
  if (s.person_height_px > 0 && s.train_resolution > 0) {
    const double scale = double(s.train_resolution) / std::max(s.crop_w, s.crop_h);
    const double uncropped = double(s.train_resolution) / std::max(s.width, s.height);
    std::snprintf(b, sizeof b, ": the person is %d px tall, %.0f px at the standard preset's %d px training size",
                  s.person_height_px, s.person_height_px * scale, s.train_resolution);
    out += b;
    if (s.cropped) {
      std::snprintf(b, sizeof b, " (%.0f px uncropped)", s.person_height_px * uncropped);
      out += b;
    }
  }
  return out;
}

std::string matting_report_line(const FitVideoSummary& s) {
  if (s.matting.empty()) return "";
  if (s.matting == "off") return "matting off (--matting off): the keypoint tool's masks";
  char b[512];
  std::snprintf(b, sizeof b, "background plate from %d of %d frames, holes %.1f %% of the frame (%.1f %% filled from the "
                "plain background beside them); ", s.plate_frames, s.plate_candidates, 100.0 * s.plate_hole_share,
                100.0 * s.plate_filled_share);
  std::string out = b;
  if (!std::isfinite(s.background_residual))
    return out + "no background seen to judge the camera by: matting off, the keypoint tool's masks";
  std::snprintf(b, sizeof b, "camera %s (background residual %.4f %s %.4f): ", s.matting_used ? "static" : "moving",
                s.background_residual, s.matting_used ? "<=" : ">", s.static_threshold);
  out += b;
  if (!s.matting_used) return out + "matting off, the keypoint tool's masks";
  out += "matting on, the dataset is premultiplied (alpha x colour against the plate)";
  if (std::isfinite(s.matted_band_share)) {
    std::snprintf(b, sizeof b, "; the plate is known at %.1f %% of the mask's edge band (%.1f %% filled; the tool's mask "
                  "elsewhere)", 100.0 * s.matted_band_share, 100.0 * s.filled_band_share);
    out += b;
  }
  return out;
}

std::string fit_report_json(const FitVideoSummary& s) {
  ojson j;
  j["format"] = "haha-fit-report";
  j["version"] = 1;
  j["input"] = s.input;
  j["dataset"] = s.out;
  j["width"] = s.width;
  j["height"] = s.height;
  j["fps"] = s.fps;
  j["decoded_frames"] = s.decoded;
  j["fitted_frames"] = s.frames.size();
  j["kept"] = s.kept;
  j["dropped"] = s.dropped;
  j["train"] = s.train;
  j["test"] = s.test;
  j["camera"] = {{"fx", s.camera.fx}, {"fy", s.camera.fy}, {"cx", s.camera.cx}, {"cy", s.camera.cy}};
  j["focal_source"] = s.focal_source;
  if (s.crop_w > 0) {
    j["crop"] = s.cropped ? ojson({{"x0", s.crop_x0}, {"y0", s.crop_y0}, {"width", s.crop_w}, {"height", s.crop_h}})
                          : ojson(nullptr);
    j["person_height_px"] = s.person_height_px;
    if (s.train_resolution > 0 && s.person_height_px > 0) {
      j["train_resolution"] = s.train_resolution;
      j["person_height_train_px"] = double(s.person_height_px) * s.train_resolution / std::max(s.crop_w, s.crop_h);
    }
  }
  if (!s.matting.empty()) {
    ojson m;
    m["mode"] = s.matting;
    m["used"] = s.matting_used;
    if (s.matting != "off") {
      m["plate_frames"] = s.plate_frames;
      m["plate_candidates"] = s.plate_candidates;
      m["hole_share"] = number_or_null(s.plate_hole_share);
      m["filled_share"] = number_or_null(s.plate_filled_share);
      m["background_residual"] = number_or_null(s.background_residual);
      m["static_threshold"] = number_or_null(s.static_threshold);
      m["camera_static"] = s.matting_used;
      if (s.matting_used) {
        m["matted_band_share"] = number_or_null(s.matted_band_share);
        m["filled_band_share"] = number_or_null(s.filled_band_share);
      }
    }
    j["matting"] = std::move(m);
  }
  j["mean_reprojection_px"] = number_or_null(s.mean_reprojection_px);
  j["mean_silhouette_iou"] = number_or_null(s.mean_silhouette_iou);
  if (!s.truth.empty()) {
    j["truth"] = s.truth;
    j["mean_joint_error_mm"] = number_or_null(s.mean_joint_error_mm);  // PA-MPJPE, pelvis + 21 body joints
    j["mean_orient_error_deg"] = number_or_null(s.mean_orient_error_deg);
  }
  ojson frames = ojson::array();
  for (const FitVideoFrameRow& r : s.frames) {
    ojson f;
    f["frame"] = r.name;
    f["source_index"] = r.source_index;
    f["kept"] = !r.dropped;
    if (r.dropped) f["reason"] = r.reason;
    f["dataset_frame"] = r.dropped ? ojson(nullptr) : ojson(r.dataset_frame);
    if (!r.dropped) f["split"] = split_name(r.split);
    f["reprojection_px"] = number_or_null(r.reprojection_px);
    f["silhouette_iou"] = number_or_null(r.silhouette_iou);
    if (!s.truth.empty()) {
      f["joint_error_mm"] = number_or_null(r.joint_error_mm);
      f["orient_error_deg"] = number_or_null(r.orient_error_deg);
    }
    frames.push_back(std::move(f));
  }
  j["frames"] = std::move(frames);
  return j.dump(1) + "\n";
}

std::string fit_report_table(const FitVideoSummary& s) {
  size_t wname = 5;
  for (const FitVideoFrameRow& r : s.frames) wname = std::max(wname, r.name.size());
  std::string out = "haha fit-video: " + s.input + " -> " + s.out + "\n";
  char line[512];
  std::snprintf(line, sizeof line, "%d frames fitted (of %d decoded), %d kept (%d train, %d test), %d dropped; "
                                   "mean reprojection %s px, mean silhouette IoU %s\n\n",
                int(s.frames.size()), s.decoded, s.kept, s.train, s.test, s.dropped,
                fixed(s.mean_reprojection_px, 2).c_str(), fixed(s.mean_silhouette_iou, 3).c_str());
  out += line;
  const bool truth = !s.truth.empty();  // a column of the joint error against --truth
  if (truth) {
    out.insert(out.size() - 2, "; mean body-joint error after Procrustes " + fixed(s.mean_joint_error_mm, 1) +
                                   " mm (PA-MPJPE), orientation " + fixed(s.mean_orient_error_deg, 1) +
                                   " deg, against " + s.truth);
  }
  if (!s.focal_source.empty())
    out.insert(out.size() - 1, "focal length " + fixed(s.camera.fx, 1) + " px: " + s.focal_source + "\n");
  for (const std::string& l : {crop_report_line(s), matting_report_line(s)})
    if (!l.empty()) out.insert(out.size() - 1, l + "\n");
  std::snprintf(line, sizeof line, "%-*s  %6s  %-7s  %7s  %6s  %6s%s  %s\n", int(wname), "frame", "source", "kept",
                "dataset", "reproj", "IoU", truth ? "  PA mm  rot deg" : "", "reason");
  out += line;
  for (const FitVideoFrameRow& r : s.frames) {
    const std::string kept = r.dropped ? "dropped" : split_name(r.split);
    char pa[48] = "";
    if (truth)
      std::snprintf(pa, sizeof pa, "  %5s  %7s", fixed(r.joint_error_mm, 1).c_str(), fixed(r.orient_error_deg, 1).c_str());
    std::snprintf(line, sizeof line, "%-*s  %6d  %-7s  %7s  %6s  %6s%s  %s\n", int(wname), r.name.c_str(), r.source_index,
                  kept.c_str(), r.dropped ? "-" : std::to_string(r.dataset_frame).c_str(),
                  fixed(r.reprojection_px, 2).c_str(), fixed(r.silhouette_iou, 3).c_str(), pa, r.reason.c_str());
    std::string l = line;
    while (l.size() > 1 && l[l.size() - 2] == ' ') l.erase(l.size() - 2, 1);  // no trailing blanks
    out += l;
  }
  return out;
}

Image draw_fit_overlay(const Image& rgb, const Camera& cam, const BodyModel& body, const std::vector<float>& verts,
                       const KeypointsFrame& kp, bool dropped) {
  Image img = rgb;
  const int W = img.width, H = img.height;
  const int half = std::max(0, std::min(W, H) / 320);  // line half-width: 1 px up to 640, then wider
  if (!verts.empty()) {
    MeshRaster raster;
    rasterize_mesh(cam, MeshView{verts.data(), body.num_verts, body.faces.data(), body.num_faces}, raster);
    const float green[3] = {0.1f, 1.0f, 0.2f};
    auto in = [&](int x, int y) { return x >= 0 && y >= 0 && x < W && y < H && raster.mask[size_t(y) * W + x] > 0.5f; };
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (in(x, y) && (!in(x - 1, y) || !in(x + 1, y) || !in(x, y - 1) || !in(x, y + 1)))
          fill_square(img, x + 0.5, y + 0.5, half, green);
  }
  if (kp.has_person()) {
    const float left[3] = {0.2f, 0.6f, 1.0f}, right[3] = {1.0f, 0.45f, 0.1f}, hidden[3] = {0.55f, 0.55f, 0.55f},
                hand[3] = {1.0f, 0.9f, 0.1f};
    for (const auto& l : kLimbs) {
      const Keypoint2 &a = kp.body[size_t(l[0])], &b = kp.body[size_t(l[1])];
      if (a.score >= kVisible && b.score >= kVisible) draw_segment(img, a, b, half, hidden);
    }
    for (int i = 0; i < kBodyKeypoints; ++i) {
      const Keypoint2& p = kp.body[size_t(i)];
      // MediaPipe numbering: odd indices are the person's left side (the nose, 0, is drawn as right).
      fill_square(img, p.x, p.y, half + 2, p.score < kVisible ? hidden : (i % 2 ? left : right));
    }
    for (const auto* h : {&kp.left_hand, &kp.right_hand})
      for (const Keypoint2& p : *h) fill_square(img, p.x, p.y, half + 1, hand);
  }
  if (dropped) {
    const float red[3] = {1.0f, 0.1f, 0.1f};
    const int b = std::max(3, std::min(W, H) / 40);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (x < b || y < b || x >= W - b || y >= H - b)
          for (int c = 0; c < 3; ++c) img.at(x, y, c) = red[c];
  }
  return img;
}

std::vector<int> sheet_frames(const std::vector<FitVideoFrameRow>& rows, int max_tiles) {
  const int n = int(rows.size());
  std::vector<int> out;
  const int k = std::min(n, std::max(0, max_tiles));
  for (int i = 0; i < k; ++i) out.push_back(int((int64_t(i) * n) / k));
  int extra = 0;
  for (int i = 0; i < n && extra < max_tiles; ++i)
    if (rows[size_t(i)].dropped && std::find(out.begin(), out.end(), i) == out.end()) out.push_back(i), ++extra;
  std::sort(out.begin(), out.end());
  return out;
}

std::string sheet_label(const FitVideoFrameRow& r) {
  // Short: a label is clipped to its tile (about 21 characters under a 128 px tile).
  if (r.dropped) return r.name + " DROP: " + r.reason;
  return r.name + " " + fixed(r.reprojection_px, 1) + "PX IOU" + fixed(r.silhouette_iou, 2);
}

}  // namespace haha
