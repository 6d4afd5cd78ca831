#include "app/fit_video_truth.h"

#include <filesystem>

#include "body/lbs.h"
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

double body_joint_pa_error_mm(const BodyModel& fit_body, const SmplxParams& fit, const BodyModel& truth_body,
                              const SmplxParams& truth) {
  auto joints = [](const BodyModel& b, const SmplxParams& p) {
    std::vector<double> v(size_t(b.num_verts) * 3), j(size_t(kNumJoints) * 3);
    Lbs<double>(b).forward(p, v.data(), j.data(), nullptr);
    std::vector<Vec3d> out;
    for (int k = 0; k < kBodyJoints; ++k) out.push_back(Vec3d::load(&j[size_t(3 * k)]));
    return out;
  };
  return 1000 * procrustes_error(joints(truth_body, truth), joints(fit_body, fit));
}

}  // namespace haha
