// `haha batch run`: one subject of a batch manifest (app/batch_manifest.h) end to end, as one
// scheduler task (a Slurm array task, a Kubernetes Indexed Job pod; docs/scale-out.md):
// fit-video when the input is a video or an image folder, then train, eval and pack, with
// the existing drivers (app/fit_video_run.h, app/train_run.h, app/eval_run.h,
// app/pack_run.h). Outputs and state go under ROOT/ID (app/batch_state.h).
//
// A subject already done is skipped (exit 0, nothing touched). One interrupted (SIGTERM from
// scancel or a pod deletion, SIGKILL, a lost node) resumes: each stage whose output exists
// is skipped, and training continues from its last checkpoint (`haha train --resume`; a
// SIGTERM writes one first), so the avatar is the same bytes as an uninterrupted run's.
// Bad input (a bad manifest line, a missing or unreadable input, a video without a person,
// an invalid dataset) writes failed.json kind bad_input and exits kBatchBadInput; it is not
// tried again until its manifest line changes (or retry_failed). Anything else (interrupted,
// out of memory, a full disk, a missing tool) writes failed.json kind retryable and exits
// kBatchRetryable; the next run resumes.
#pragma once

#include <functional>
#include <string>

#include "app/batch_state.h"

namespace haha {

struct BatchRunOptions {
  std::string manifest;
  std::string root;
  int index = -1;            // < 0: SLURM_ARRAY_TASK_ID, else JOB_COMPLETION_INDEX
  bool retry_failed = false;  // try a bad-input subject again even with the same line
  std::string keypoint_tool;  // fit-video's tools/keypoints ("" = found next to haha)
  double heartbeat_s = 10;    // running.json rewritten this often
  std::function<void(const std::string&)> log;  // progress lines (null: stdout)
};

struct BatchRunResult {
  int exit_code = kBatchDone;  // BatchExit
  int index = -1;
  std::string id;
  std::string message;         // one line: what happened
  bool skipped = false;        // nothing to do (done, or bad input not retried)
};

// Never throws for the subject's problems: they end in the result (and failed.json).
BatchRunResult run_batch_subject(const BatchRunOptions& opt);

// Input kinds.
enum class BatchInputKind { missing, video, images, dataset, unknown };
BatchInputKind batch_input_kind(const std::string& path);
const char* batch_input_kind_name(BatchInputKind k);

}  // namespace haha
