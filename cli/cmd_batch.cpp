// `haha batch`: many subjects as scheduler tasks (Slurm job arrays, Kubernetes Indexed Jobs).
// `batch run` takes one subject of a manifest end to end (app/batch_run.h); `batch status`
// reports every subject (app/batch_state.h). Manifest format: app/batch_manifest.h,
// docs/scale-out.md.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "app/batch_run.h"
#include "app/batch_state.h"
#include "command.h"
#include "core/parallel.h"

HAHA_COMMAND(batch) {
  auto* sub = app.add_subcommand("batch", "Many subjects, one scheduler task each (Slurm job arrays, Kubernetes Indexed Jobs)");
  sub->require_subcommand(1);

  auto r = std::make_shared<haha::BatchRunOptions>();
  auto* run = sub->add_subcommand(
      "run",
      "Subject I of MANIFEST end to end (fit-video for videos / image folders, train, eval, pack) into OUT/ID. Exit 0 done "
      "or already done, 65 bad input (do not retry), 75 retryable (run again: it resumes), 64 usage");
  run->add_option("manifest", r->manifest, "manifest: one subject a line, ID INPUT [key=value ...]")->required();
  run->add_option("--out", r->root, "output root; subject ID goes to OUT/ID")->required();
  run->add_option("--index", r->index,
                  "subject index, 0-based among the manifest's subject lines (default: SLURM_ARRAY_TASK_ID, else "
                  "JOB_COMPLETION_INDEX)");
  run->add_flag("--retry-failed", r->retry_failed, "try a subject that failed as bad input again with the same line");
  run->add_option("--keypoint-tool", r->keypoint_tool, "fit-video's tools/keypoints folder (default: found next to haha)");
  run->add_option("--heartbeat", r->heartbeat_s, "seconds between rewrites of OUT/ID/running.json")->capture_default_str();
  run->callback([r] {
    // Under Slurm, one thread per allocated CPU unless --threads says otherwise.
    const char* cpus = std::getenv("SLURM_CPUS_PER_TASK");
    if (haha::cli::requested_threads() == 0 && cpus && std::atoi(cpus) > 0)
      haha::set_num_threads(std::atoi(cpus));
    const haha::BatchRunResult res = haha::run_batch_subject(*r);
    if (res.exit_code == haha::kBatchDone)
      std::printf("haha batch: %s\n", res.message.c_str());
    else
      std::fprintf(stderr, "haha: error: %s\n", res.message.c_str());
    std::fflush(stdout);
    if (res.exit_code != 0) throw CLI::RuntimeError(res.exit_code);
  });

  struct StatusOpts {
    std::string manifest, root;
    bool json = false;
    double stale = 120;
  };
  auto st = std::make_shared<StatusOpts>();
  auto* status = sub->add_subcommand("status", "Every subject of MANIFEST under OUT: done / running / failed / pending, why");
  status->add_option("manifest", st->manifest, "the manifest")->required();
  status->add_option("--out", st->root, "output root")->required();
  status->add_flag("--json", st->json, "JSON instead of the table");
  status->add_option("--stale-after", st->stale,
                     "seconds without a heartbeat after which a task on another host counts as gone")
      ->capture_default_str();
  status->callback([st] {
    const haha::BatchManifest m = haha::read_batch_manifest(st->manifest);
    std::vector<haha::SubjectStatus> all;
    for (const haha::BatchSubject& s : m.subjects) all.push_back(haha::read_subject_status(s, st->root, st->stale));
    std::printf("%s", st->json ? haha::batch_status_json(all, st->manifest, st->root).c_str()
                               : haha::batch_status_table(all).c_str());
  });
}
