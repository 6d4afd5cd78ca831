#include "fit/fit_video_truth.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/error.h"
#include "core/procrustes.h"
#include "data/dataset.h"
#include "io/body_model_io.h"

namespace haha {

namespace fs = std::filesystem;

namespace {
constexpr int kBodyJoints = 22;  // pelvis + 21 body joints (SMPL-X order)
}

FitVideoTruth read_fit_video_truth(const std::string& dir, const BodyModel& fallback_body) {
  std::error_code ec;
  if (!fs::is_regular_file(fs::path(dir) / "dataset.json", ec))
    fail(dir, "no dataset.json: --truth needs a native dataset with the true fits (e.g. the synth/ folder of "
              "scripts/make-test-video.sh)");
  FitVideoTruth t;
  t.dir = dir;
  const Dataset ds = read_dataset(dir, LoadPixels::headers);
  if (ds.frames.empty()) fail(dir, "the dataset holds no frames, so no fits to compare with");
  for (const DatasetFrame& f : ds.frames) t.cameras.push_back(f.camera);
  if (!ds.params_true.empty()) {
    t.params = ds.params_true;
  } else {
    for (const DatasetFrame& f : ds.frames) t.params.push_back(f.params);
  }
  const fs::path body = fs::path(dir) / "body_model.npz";
  t.own_body = fs::is_regular_file(body, ec);
  t.body = t.own_body ? load_body_model(body.string()) : fallback_body;
  return t;
}

void check_truth_frames(const FitVideoTruth& t, int decoded_frames) {
  if (int(t.params.size()) < decoded_frames)
    fail(t.dir, "has fits for " + std::to_string(t.params.size()) + " frames, the video " +
                    std::to_string(decoded_frames) + ": --truth needs one per decoded frame, in order");
}

double body_joint_pa_error_mm(const Lbs<double>& fit_body, const SmplxParams& fit, const Lbs<double>& truth_body,
                              const SmplxParams& truth) {
  auto joints = [](const Lbs<double>& b, const SmplxParams& p) {
    std::vector<double> v(size_t(b.num_verts()) * 3), j(size_t(kNumJoints) * 3);
    b.forward(p, v.data(), j.data(), nullptr);
    std::vector<Vec3d> out;
    for (int k = 0; k < kBodyJoints; ++k) out.push_back(Vec3d::load(&j[size_t(3 * k)]));
    return out;
  };
  return 1000 * procrustes_error(joints(truth_body, truth), joints(fit_body, fit));
}

double body_orient_error_deg(const Camera& fit_camera, const SmplxParams& fit, const Camera& truth_camera,
                             const SmplxParams& truth) {
  auto sq = [](double x) { return x * x; };
  auto seen = [](const Camera& c, const SmplxParams& p) {
    return c.cast<double>().R * rodrigues(Vec3d(p.pose[0], p.pose[1], p.pose[2]));
  };
  const Mat3<double> d = seen(fit_camera, fit) * transpose(seen(truth_camera, truth));
  // atan2 of sin and cos (not acos alone): exact near 0 degrees, where acos loses digits.
  const double s = 0.5 * std::sqrt(sq(d.a[2][1] - d.a[1][2]) + sq(d.a[0][2] - d.a[2][0]) + sq(d.a[1][0] - d.a[0][1]));
  const double c = (d.a[0][0] + d.a[1][1] + d.a[2][2] - 1) / 2;
  return std::atan2(s, c) * 180 / std::numbers::pi;
}

}  // namespace haha
