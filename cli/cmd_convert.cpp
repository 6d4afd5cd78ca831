// `haha convert`: real data (X-Humans, PeopleSnapshot/InstantAvatar, SMPLify-X fits) into
// the native dataset format (data/dataset.h) that `haha train` reads. Every input file of
// the selected frames is validated before anything is written; the output directory
// appears only when complete.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "app/smpl_fit.h"
#include "command.h"
#include "core/error.h"
#include "data/dataset.h"
#include "data/readers.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "io/smpl_model_io.h"

namespace {

struct ConvertArgs {
  std::string from, out, body, hand_mean = "flat", gender, train_frames, test_frames, smpl_model, smpl_correspondence;
  int fit_iterations = 500;
  std::vector<std::string> in, test;
  int size = 0, every = 1, max_frames = 0;
  double fps = 30, focal = 5000, depth_threshold = 700;
  bool no_crop = false;
};

void run_convert(const ConvertArgs& a) {
  using namespace haha;
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
    // SMPL poses become SMPL-X by fitting (app/smpl_fit.h), never by copying numbers.
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

}  // namespace

HAHA_COMMAND(convert) {
  auto args = std::make_shared<ConvertArgs>();
  auto* sub = app.add_subcommand("convert", "Convert real capture data into the native dataset format");
  sub->add_option("--from", args->from, "Input format: xhumans, peoplesnapshot or smplifyx")->required();
  sub->add_option("--in", args->in,
                  "Input: X-Humans take folder(s) (training), the InstantAvatar PeopleSnapshot folder, or a "
                  "folder with images/, masks/ and results/<name>/000.pkl or smplx/<name>.pkl")
      ->required();
  sub->add_option("--out", args->out, "Output dataset directory (replaced only if empty or a haha dataset)")
      ->required();
  sub->add_option("--test", args->test, "X-Humans: test take folder(s)");
  sub->add_option("--size", args->size, "Resize so the longer side has this many pixels (default: keep)");
  sub->add_option("--every", args->every, "Keep every k-th frame (default 1)");
  sub->add_option("--max-frames", args->max_frames, "At most this many frames per take / split (default: all)");
  sub->add_option("--model,--body", args->body,
                  "SMPL-X model .npz: fitting target for peoplesnapshot, PCA hand poses, --hand-mean model");
  sub->add_option("--smpl-model", args->smpl_model,
                  "peoplesnapshot: the SMPL model .npz its poses were fitted with (SMPL file keys, 24 joints)");
  sub->add_option("--smpl-correspondence", args->smpl_correspondence,
                  "peoplesnapshot: .npz with smpl_to_smplx (V_smpl,) = SMPL-X vertex of each SMPL vertex or -1; "
                  "without it the fit uses joints 0-21 only");
  sub->add_option("--fit-iterations", args->fit_iterations, "peoplesnapshot: SMPL-X fit iterations (default 500)");
  sub->add_option("--hand-mean", args->hand_mean,
                  "Hand poses are relative to: flat (default) or model (add the model's hands_mean, as "
                  "SMPLify-X fits with its default flat_hand_mean=False)");
  sub->add_option("--fps", args->fps, "Frame rate of the source video (default 30)");
  sub->add_option("--gender", args->gender, "neutral, male or female (default: from the data, else neutral)");
  sub->add_option("--train-frames", args->train_frames,
                  "START:END[:STEP] of the sorted frames used for training (peoplesnapshot default 0:456:4, "
                  "smplifyx default all)");
  sub->add_option("--test-frames", args->test_frames,
                  "START:END[:STEP] of the test frames (peoplesnapshot default 456:676:4, smplifyx default none)");
  sub->add_option("--focal", args->focal, "SMPLify-X: focal length in pixels when the fits store none (5000)");
  sub->add_option("--depth-threshold", args->depth_threshold,
                  "X-Humans: mask = depth.max() - depth > this, in stored depth units (default 700)");
  sub->add_flag("--no-crop", args->no_crop, "X-Humans: keep the full frame (default: centre square crop)");
  sub->callback([args] { run_convert(*args); });
}
