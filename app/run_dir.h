// The run directory: the one place that knows its layout. `haha train` writes it,
// `haha eval`, `haha bench` and `haha pack` read it, `haha unpack` writes a packable one.
//
// RUN/ layout:
//   config.json              {"format": "haha-run", "version": 1, "model": PATH,
//                             "data": ABS_PATH, "lpips_weights": PATH|null,
//                             "config": {every TrainConfig key: value}}
//                            (an unpacked or hand-made avatar directory: only "model",
//                            and "unpacked_from" when `haha unpack` wrote it)
//   checkpoint.npz           latest state (atomic; --resume continues from it)
//   checkpoint_stage{1,2,3}.npz  state at each stage end
//   avatar.npz               the HAHA avatar (filtered Gaussians + texture; format/avatar_npz.h)
//   avatar_stage1.npz        the full-Gaussian avatar of stage 1 with the final texture
//   smplx_refined.npz        the refined per-frame fits of the training frames
//   rest_offsets.npy         (V, 3) the clothed surface's rest displacement, when the run fitted
//                            one (s0.surface; --resume reads it back; avatar.npz carries it too)
//   garment.npz              the garment appended to the body (s0.garment), when one was made
//   texture_evidence.npy     (S, S) float32: how much the training frames saw each texel of the
//                            final texture, in frontal pixels (train/texture_evidence.h)
//   train_summary.json       stage wall times, Gaussian counts, skipped steps, last losses
//   report.json, report.md, eval_sheet.png   written by `haha eval`
//   body.npz                 the body model, in an unpacked avatar's directory
#pragma once

#include <array>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "train/config.h"
#include "train/trainer.h"

namespace haha {

// Paths of a run directory's files.
struct RunDir {
  std::string dir;
  explicit RunDir(std::string d) : dir(std::move(d)) {}
  std::string file(const std::string& name) const;  // dir / name
  std::string config() const { return file("config.json"); }
  std::string checkpoint() const { return file("checkpoint.npz"); }
  std::string stage_checkpoint(int stage) const { return file("checkpoint_stage" + std::to_string(stage) + ".npz"); }
  std::string avatar() const { return file("avatar.npz"); }
  std::string stage1_avatar() const { return file("avatar_stage1.npz"); }
  std::string refined_fits() const { return file("smplx_refined.npz"); }
  std::string rest_offsets() const { return file("rest_offsets.npy"); }
  std::string garment() const { return file("garment.npz"); }
  std::string texture_evidence() const { return file("texture_evidence.npy"); }
  std::string train_summary() const { return file("train_summary.json"); }
  std::string report_json() const { return file("report.json"); }
  std::string report_md() const { return file("report.md"); }
  std::string eval_sheet() const { return file("eval_sheet.png"); }
};

// ---- config.json ------------------------------------------------------------------------
struct RunInfo {
  std::string model_path;          // absolute, or resolved against the run directory
  std::string data_path;           // absolute; empty for an unpacked avatar
  std::string lpips_weights_path;  // empty = none
  std::string unpacked_from;       // the .glb an unpacked avatar came from
  bool trained = true;             // false: no "format"/training config, only "model"
  TrainConfig config;
};
std::string run_info_to_json(const RunInfo& info);
// Throws haha::Error "<path>: <key>: <problem>". A relative "model" is looked up in the
// run directory first.
RunInfo read_run_info(const RunDir& run);
void write_run_info(const RunDir& run, const RunInfo& info);  // atomic
// read_run_info, and an error naming config.json when the run was not trained here
// (`what` says which command needs the training config).
RunInfo read_trained_run_info(const RunDir& run, const std::string& what);

// Stage wall times from RUN/train_summary.json ({0, 0, 0} when the file is absent).
std::array<double, 3> read_train_seconds(const RunDir& run);

// ---- checkpoints ------------------------------------------------------------------------
void write_checkpoint(const std::string& path, const TrainCheckpoint& ck);  // atomic npz
TrainCheckpoint read_checkpoint(const std::string& path);  // haha::Error naming the file

// RUN/texture_evidence.npy for a texture of side `size`; empty when the file is absent.
// Throws haha::Error "<path>: <problem>" for a wrong shape or a negative / non-finite value.
std::vector<float> read_texture_evidence(const RunDir& run, int size);

// ---- avatars ------------------------------------------------------------------------------
// RUN/avatar.npz + the body model named by config.json (or `model_path` when non-empty).
// Checks the Gaussians' face indices against the model.
Avatar load_run_avatar(const RunDir& run, const std::string& model_path = "");
// RUN/avatar_stage1.npz with `body` (the final avatar's).
Avatar load_stage1_avatar(const RunDir& run, const BodyModel& body);

// An unpacked avatar as a run directory that `haha pack` takes again: avatar.npz,
// body.npz and config.json.
void write_unpacked_run(const RunDir& run, const Avatar& avatar, const std::string& unpacked_from);

}  // namespace haha
