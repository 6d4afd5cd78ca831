#include "app/convert_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "core/error.h"
#include "data/dataset.h"
#include "data/readers.h"
#include "fit/smpl_fit.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "io/smpl_model_io.h"

namespace haha {

void run_convert(const ConvertRunOptions& a) {
  std::unique_ptr<BodyModel> model;
  if (!a.body.empty()) model = std::make_unique<BodyModel>(load_body_model(a.body));
  if (a.hand_mean != "flat" && a.hand_mean != "model")
    fail("--hand-mean", "'" + a.hand_mean + "' is neither flat nor model");
  if (a.hand_mean == "model" && !model) fail("--hand-mean", "'model' needs --model (the model's hands_mean)");
  if (a.fit_iterations < 0 || a.fit_iterations > 100000) fail("--fit-iterations", "must be in 0..100000");
  if (a.every < 1) fail("--every", "must be at least 1");
  if (a.size < 0) fail("--size", "must be positive");
  if (!a.gender.empty() && a.gender != "neutral" && a.gender != "male" && a.gender != "female")
    fail("--gender", "'" + a.gender + "' is not neutral, male or female");

  auto common = [&](ConvertOptions& o) {
    o.max_side = a.size;
    o.every = a.every;
    o.max_frames = a.max_frames;
    o.model = model.get();
    o.flat_hand_mean = a.hand_mean == "flat";
    o.fps = a.fps;
    o.gender = a.gender;
  };
  auto one_input = [&]() -> const std::string& {
    if (a.in.size() != 1) fail("--in", "--from " + a.from + " takes one input directory");
    if (!a.test.empty()) fail("--test", "only --from xhumans takes separate test takes (use --test-frames)");
    return a.in.front();
  };

  Dataset ds;
  if (a.from == "xhumans") {
    XHumansOptions o;
    common(o);
    o.train_takes = a.in;
    o.test_takes = a.test;
    o.square_crop = !a.no_crop;
    o.depth_threshold = float(a.depth_threshold);
    if (!a.train_frames.empty() || !a.test_frames.empty())
      fail("--train-frames", "X-Humans splits are whole takes: give test takes with --test");
    ds = read_xhumans(o);
  } else if (a.from == "peoplesnapshot") {
    if (a.smpl_model.empty())
      fail("--smpl-model", "missing: PeopleSnapshot poses are SMPL fits; give the SMPL model file (e.g. SMPL_NEUTRAL.npz) "
                           "and the SMPL-X model (--model) so that SMPL-X is fitted to them");
    if (!model) fail("--model", "missing: converting PeopleSnapshot fits SMPL-X, which needs the SMPL-X model file");
    PeopleSnapshotOptions o;
    common(o);
    o.dir = one_input();
    auto smpl = std::make_shared<BodyModel>(load_smpl_model(a.smpl_model));
    std::vector<int32_t> corr;
    if (!a.smpl_correspondence.empty()) {
      const Npz c = Npz::read(a.smpl_correspondence);
      for (double v : npz_numbers(c, "smpl_to_smplx", {smpl->num_verts})) {
        if (v != std::floor(v) || v < -1 || v >= model->num_verts)
          fail(a.smpl_correspondence + ": smpl_to_smplx", "entry " + std::to_string(v) + " is not -1 or an SMPL-X vertex");
        corr.push_back(int32_t(v));
      }
    }
    o.fit_smpl = [smpl, corr, &model, &a](const std::vector<SmplxParams>& frames, const std::vector<int>& source) {
      SmplFitOptions fo;
      fo.iterations = a.fit_iterations;
      std::printf("fitting SMPL-X to %zu SMPL frames (%s, %s)\n", frames.size(), a.smpl_model.c_str(),
                  corr.empty() ? "joints 0-21 only: no --smpl-correspondence" : "joints 0-21 and corresponded vertices");
      const SmplFitResult r = fit_smplx_to_smpl(*smpl, *model, corr, frames, {}, fo);
      double worst = 0;
      for (size_t i = 0; i < r.frames.size(); ++i) {
        const double v = r.vertex_mm.empty() ? -1 : r.vertex_mm[i];
        worst = std::max(worst, std::max(r.joint_mm[i], v));
        if (v >= 0) std::printf("frame %d: residual joints %.2f mm, vertices %.2f mm\n", source[i], r.joint_mm[i], v);
        else std::printf("frame %d: residual joints %.2f mm\n", source[i], r.joint_mm[i]);
      }
      std::printf("SMPL-X fit: worst per-frame mean residual %.2f mm\n", worst);
      return r.frames;
    };
    if (!a.train_frames.empty()) o.train = parse_frame_range(a.train_frames, "--train-frames");
    if (!a.test_frames.empty()) o.test = parse_frame_range(a.test_frames, "--test-frames");
    ds = read_peoplesnapshot(o);
  } else if (a.from == "smplifyx") {
    SmplifyxOptions o;
    common(o);
    o.dir = one_input();
    o.focal = a.focal;
    if (!a.train_frames.empty()) o.train = parse_frame_range(a.train_frames, "--train-frames");
    if (!a.test_frames.empty()) o.test = parse_frame_range(a.test_frames, "--test-frames");
    ds = read_smplifyx(o);
  } else {
    fail("--from", "'" + a.from + "' is not xhumans, peoplesnapshot or smplifyx");
  }
  write_dataset(ds, a.out);
  std::printf("wrote %s: %zu frames (%zu train, %zu test), %dx%d, %s camera\n", a.out.c_str(), ds.frames.size(),
              ds.indices(Split::train).size(), ds.indices(Split::test).size(), ds.width, ds.height,
              ds.is_static_camera() ? "static" : "per-frame");
}

}  // namespace haha
