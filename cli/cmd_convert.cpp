// `haha convert`: real capture data into the native dataset format (app/convert_run.h).
#include <memory>

#include "app/convert_run.h"
#include "command.h"

HAHA_COMMAND(convert) {
  auto args = std::make_shared<haha::ConvertRunOptions>();
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
  sub->callback([args] { haha::run_convert(*args); });
}
