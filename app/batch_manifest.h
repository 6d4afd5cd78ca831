// The batch manifest of `haha batch`: one subject a line, mapped onto scheduler tasks
// (Slurm job arrays, Kubernetes Indexed Jobs; docs/scale-out.md).
//
//   # comment; blank lines are ignored
//   * preset=standard s2.steps=2000             options every subject gets (its own line wins)
//   alice   videos/alice.mp4   fit:fps=10 fit:test-every=10
//   bob     frames/bob/        fit:focal-35mm=26 eval:tto-steps=0
//   carol   data/carol         s1.steps=800 pack:mesh-compression=none
//
// A line is ID INPUT [OPTION ...], separated by blanks; a token may be "double quoted" (\" and
// \\ inside). The index of a subject (--index, SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX)
// counts subject lines from 0 in file order. ID: letters, digits, '.', '_', '-' (not starting
// with '.'), unique; it names the subject's folder ROOT/ID. INPUT, relative to the manifest's
// folder: a video file or a folder of images (`haha fit-video` makes the dataset), or a native
// dataset folder (one with dataset.json, trained as it is).
//
// Options (key=value):
//   KEY=V          a training config key (`haha train --list-keys`), as `haha train KEY=V`
//   preset=P       tiny | standard | paper (default standard);  device=D  cpu | cuda | auto (default cpu)
//   model=PATH     body model .npz (default: the dataset's body_model.npz)
//   fit:K=V        `haha fit-video --K V`: fps, test-every, test-from, focal, focal-35mm, fov,
//                  frames, mask, keypoints, robust-smoothness
//   eval:K=V       `haha eval --K V`: tto-steps, frames, split (train | test | none),
//                  background, antialias (true | false)
//   pack:K=V       `haha pack --K V`: mesh-compression, texture, texture-size, texture-quality,
//                  lod, lossless, khr-gaussian-splatting, normals, keep-face-order (true | false)
// A line's problem (unknown option, bad value, duplicate id) is that subject's bad input; the
// other subjects still run. Only an unreadable manifest fails every index.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace haha {

struct BatchSubject {
  int index = -1;          // 0-based among subject lines
  int line = 0;            // 1-based line number in the manifest
  std::string id;
  std::string input;       // as written
  std::string input_path;  // resolved against the manifest's folder
  std::vector<std::pair<std::string, std::string>> options;  // defaults ('*' lines) first, then its own
  std::string error;       // non-empty: the line is bad input (why), the fields may be partial
  // The options sorted out (valid only when error is empty).
  std::string preset = "standard", device = "cpu", model;
  std::vector<std::string> train_overrides;                       // key=value
  std::vector<std::pair<std::string, std::string>> fit, eval, pack;  // without their prefix
  // A fingerprint of what the subject's outputs depend on (id, input, options): a subject
  // started with another line is not mixed with it.
  std::string fingerprint() const;
};

struct BatchManifest {
  std::string path;  // as given
  std::vector<BatchSubject> subjects;
};

// Parses manifest text; `base_dir` resolves relative inputs. Throws haha::Error only for
// what makes the whole file unusable (an unterminated quote is a line error).
BatchManifest parse_batch_manifest(const std::string& text, const std::string& path, const std::string& base_dir);
// Reads and parses a manifest file (haha::Error naming it when unreadable).
BatchManifest read_batch_manifest(const std::string& path);

// Splits one line into tokens (blanks separate, "..." quotes, # starts a comment outside
// quotes). Sets `error` on an unterminated quote.
std::vector<std::string> split_manifest_line(const std::string& line, std::string& error);

// Validates every option of `s` and fills its sorted-out fields; sets s.error on a problem.
void resolve_subject_options(BatchSubject& s);

// The subject index of a task: `index` when >= 0, else SLURM_ARRAY_TASK_ID, else
// JOB_COMPLETION_INDEX (from `getenv`); -1 when none is set. haha::Error when the variable
// is not a non-negative integer.
int batch_task_index(int index, const std::function<const char*(const char*)>& getenv_fn);

}  // namespace haha
