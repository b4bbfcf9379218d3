// The Slurm executor (pipeline.executor: slurm): a stage runs as batch jobs on
// a cluster instead of as a child process, writing into the same content-keyed
// cache, which must be on a folder every node sees (the workspace and the build's
// bin/ folder on a shared file system).
//
// A stage with per-photo work (StageDef::shard_steps > 0) runs each of its passes
// as one job array (`sbatch --array`), every task doing a shard of the photos
// (`--shard I/N --step S`, core/stage.h); the next pass is submitted when the
// last one has ended, then one job runs the stage whole, which finds every photo
// done and writes the stage's summaries. Any other stage runs as one job. Each
// task records its exit code in a file, so the executor needs only `sbatch`,
// `squeue` and `scancel` (no accounting database): a task that left no exit code
// was killed (scancel, node failure, time limit) and is resubmitted alone, up to
// kMaxAttempts times; a task that exited non-zero fails the stage with its reason.
// The orchestrator's own process does no work but polling.
#pragma once

#include <string>
#include <vector>

#include "pipeline/subprocess.h"

namespace relight::pipeline {

struct SlurmOptions {
  int shards = 16;                       // tasks per job array
  int cpus_per_task = 2;                 // --cpus-per-task, and the stage's --threads
  std::vector<std::string> sbatch_args;  // added to every sbatch command (partition, time, account)
  double poll_seconds = 2;               // between two squeue calls
};

// One stage's work for the cluster.
struct SlurmStageWork {
  std::string stage;
  std::vector<std::string> argv;  // the whole stage's command (executable first), without --shard/--step
  std::string output_dir;         // the stage's output folder; job scripts, logs and exit codes go to slurm/
  int shard_steps = 0;            // passes of per-photo work to run as job arrays first; 0: none
};

// Submits `work` and waits for it. The result is the last job's: ok, an exit code (its reason is in
// output_dir/error.txt, copied there from a failed shard), or signaled with SIGINT/SIGTERM/SIGHUP when the
// run was interrupted (the jobs are cancelled). Throws UserError when Slurm cannot be used.
ProcessResult RunOnSlurm(const SlurmStageWork& work, const SlurmOptions& options);

// Tasks of one submission that are tried at most this often (a killed task is resubmitted alone).
inline constexpr int kMaxSlurmAttempts = 3;

}  // namespace relight::pipeline
