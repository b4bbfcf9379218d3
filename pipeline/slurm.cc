#include "pipeline/slurm.h"

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/text.h"
#include "pipeline/interrupt.h"

namespace relight::pipeline {
namespace fs = std::filesystem;

namespace {

// How long squeue may keep failing (controller restarting, network) before the run gives up.
constexpr double kSqueueOutageSeconds = 300;

std::string ShellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string FirstLine(const std::string& s) {
  const std::string t = TrimWhitespace(s);
  const size_t nl = t.find('\n');
  return nl == std::string::npos ? t : t.substr(0, nl);
}

// Sleeps `seconds` in short steps; returns false as soon as the run is interrupted.
bool SleepUnlessInterrupted(double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (InterruptSignal() != 0) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return InterruptSignal() == 0;
}

// "0,3,5" for sbatch --array.
std::string ArraySpec(const std::vector<int>& tasks) {
  std::string spec;
  for (int t : tasks) spec += (spec.empty() ? "" : ",") + std::to_string(t);
  return spec;
}

// One submission unit: `count` tasks of the same command (the shards of a pass, or 1 whole run).
struct TaskSet {
  std::string tag;                // "step0", "whole": names scripts, logs and exit-code files
  std::string label;              // for the log and progress bar
  std::vector<std::string> argv;  // the command; "$i" in its --shard= argument becomes the task index
  int count = 1;
  std::string error_file;  // relative to the output folder, with "$i"
};

class SlurmSubmitter {
 public:
  SlurmSubmitter(const SlurmStageWork& work, const SlurmOptions& options)
      : work_(work), options_(options), dir_(JoinPath(work.output_dir, "slurm")) {
    EnsureDir(dir_);
  }

  // Runs every task of `set` to completion; returns the stage's result.
  ProcessResult Run(const TaskSet& set) {
    std::map<int, int> attempts;
    std::vector<int> pending(set.count);
    for (int i = 0; i < set.count; ++i) pending[i] = i;
    const std::string script = WriteScript(set);
    Progress progress(work_.stage + ": " + set.label, set.count);
    while (!pending.empty()) {
      for (int i : pending) {
        std::error_code ec;
        fs::remove(RcPath(set, i), ec);
        ++attempts[i];
      }
      const std::string job = Submit(set, script, pending);
      RLOG_INFO("{}: {}: Slurm job {} ({} task{}; logs {}/{}_*.out)", work_.stage, set.label, job, pending.size(),
                pending.size() == 1 ? "" : "s", dir_, set.tag);
      if (!WaitForJob(job, set, pending, &progress)) return Interrupted(job);
      std::vector<int> killed;
      for (int i : pending) {
        const std::optional<int> rc = ReadRc(set, i);
        if (rc && *rc == 0) continue;
        if (rc && *rc < 128) return Failed(set, i, *rc);
        killed.push_back(i);  // no exit code, or the stage died of a signal inside the job
      }
      for (int i : killed) {
        if (attempts[i] >= kMaxSlurmAttempts) {
          std::error_code ec;
          // Slurm creates the output file when the task starts, on the node that runs it.
          const std::string reason =
              fs::exists(OutPath(set, i), ec)
                  ? "was killed " + std::to_string(attempts[i]) +
                        " times (cancelled, out of memory, time limit or a failed node); its output: " + OutPath(set, i)
                  : "ended " + std::to_string(attempts[i]) + " times without leaving its output " + OutPath(set, i) +
                        " here: the workspace must be on a file system the compute nodes share, at the same path";
          WriteFileAtomic(JoinPath(work_.output_dir, "error.txt"),
                          "Slurm task " + std::to_string(i) + " of " + set.label + " " + reason + "\n");
          ProcessResult r;
          r.signaled = true;
          r.signal = SIGKILL;
          return r;
        }
        RLOG_WARN(
            "{}: {}: task {} ended without an exit code (cancelled, killed or a failed node); resubmitting "
            "it alone (attempt {} of {})",
            work_.stage, set.label, i, attempts[i] + 1, kMaxSlurmAttempts);
      }
      pending = killed;
    }
    progress.Finish();
    ProcessResult ok;
    ok.exit_code = 0;
    return ok;
  }

 private:
  std::string RcPath(const TaskSet& set, int i) const {
    return JoinPath(dir_, set.tag + "_" + std::to_string(i) + ".rc");
  }
  std::string OutPath(const TaskSet& set, int i) const {
    return JoinPath(dir_, set.tag + "_" + std::to_string(i) + ".out");
  }

  std::string WriteScript(const TaskSet& set) const {
    std::ostringstream s;
    s << "#!/bin/bash\n# " << work_.stage << ", " << set.label << ": written by `pipeline` (executor slurm)\n";
    s << "i=\"${SLURM_ARRAY_TASK_ID:-0}\"\n";
    for (size_t k = 0; k < set.argv.size(); ++k) {
      std::string arg = ShellQuote(set.argv[k]);
      // The task index in --shard: close the single quotes, expand $i, reopen.
      if (set.argv[k].rfind("--shard=", 0) == 0) arg.replace(arg.find("$i"), 2, "'\"$i\"'");
      s << (k == 0 ? "" : " ") << arg;
    }
    const std::string rc = ShellQuote(JoinPath(dir_, set.tag + "_")) + "\"$i\"";
    s << "\nrc=$?\necho \"$rc\" > " << rc << "'.rc.tmp' && mv -f " << rc << "'.rc.tmp' " << rc << "'.rc'\n";
    s << "exit \"$rc\"\n";
    const std::string path = JoinPath(dir_, set.tag + ".sh");
    WriteFileAtomic(path, s.str());
    fs::permissions(path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec,
                    fs::perm_options::replace);
    return path;
  }

  std::string Submit(const TaskSet& set, const std::string& script, const std::vector<int>& tasks) const {
    std::vector<std::string> argv{"sbatch",
                                  "--parsable",
                                  "--job-name=relight-" + work_.stage + "-" + set.tag,
                                  "--array=" + ArraySpec(tasks),
                                  "--cpus-per-task=" + std::to_string(options_.cpus_per_task),
                                  "--output=" + JoinPath(dir_, set.tag + "_%a.out"),
                                  "--chdir=" + work_.output_dir};
    argv.insert(argv.end(), options_.sbatch_args.begin(), options_.sbatch_args.end());
    argv.push_back(script);
    const CommandOutput out = RunCommandCapture(argv);
    if (out.exit_code == 127) {
      RELIGHT_USER_ERROR() << "pipeline.executor: slurm needs Slurm's `sbatch` on PATH (run on a login node of "
                           << "the cluster, or set pipeline.executor: local)";
    }
    const std::string id = FirstLine(out.out).substr(0, FirstLine(out.out).find(';'));
    if (out.exit_code != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos) {
      RELIGHT_USER_ERROR() << "sbatch refused the job of stage '" << work_.stage << "' (" << set.label
                           << "): " << FirstLine(out.err.empty() ? out.out : out.err)
                           << "; check pipeline.slurm_sbatch_args and pipeline.slurm_cpus_per_task";
    }
    return id;
  }

  // Polls squeue until no task of `job` is pending or running. False when the run was interrupted.
  bool WaitForJob(const std::string& job, const TaskSet& set, const std::vector<int>& tasks, Progress* progress) {
    double outage = 0;
    std::set<int> seen_done;
    for (;;) {
      const CommandOutput q = RunCommandCapture({"squeue", "-h", "-j", job, "-o", "%i %T"});
      bool active = true;
      if (q.exit_code == 0) {
        outage = 0;
        active = !TrimWhitespace(q.out).empty();
      } else if (q.err.find("Invalid job id") != std::string::npos) {
        active = false;  // the controller forgot the finished job already
      } else {
        outage += options_.poll_seconds;
        if (outage > kSqueueOutageSeconds) {
          RELIGHT_USER_ERROR() << "squeue has failed for " << static_cast<int>(outage) << " s while waiting for job "
                               << job << " (" << FirstLine(q.err) << "); the job may still be running: cancel "
                               << "it with `scancel " << job << "` or rerun `pipeline run` when Slurm is back";
        }
      }
      for (int i : tasks) {
        if (seen_done.count(i) == 0 && ReadRc(set, i)) {
          seen_done.insert(i);
          progress->Advance();
        }
      }
      if (!active) {
        // A file written on another node may reach this one's view of a shared folder a little later.
        if (seen_done.size() < tasks.size() && !SleepUnlessInterrupted(options_.poll_seconds)) return false;
        return true;
      }
      if (!SleepUnlessInterrupted(options_.poll_seconds)) return false;
    }
  }

  std::optional<int> ReadRc(const TaskSet& set, int i) const {
    std::error_code ec;
    if (!fs::is_regular_file(RcPath(set, i), ec)) return std::nullopt;
    try {
      return std::stoi(ReadFileToString(RcPath(set, i)));
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }

  ProcessResult Failed(const TaskSet& set, int i, int rc) const {
    std::string error_file = set.error_file;
    for (size_t pos; (pos = error_file.find("$i")) != std::string::npos;) error_file.replace(pos, 2, std::to_string(i));
    std::string reason;
    try {
      reason = TrimWhitespace(ReadFileToString(JoinPath(work_.output_dir, error_file)));
    } catch (const std::exception&) {
    }
    if (reason.empty())
      reason = "exit code " + std::to_string(rc) + " without a reason; its output: " + OutPath(set, i);
    if (set.count > 1) reason = set.label + ", task " + std::to_string(i) + ": " + reason;
    WriteFileAtomic(JoinPath(work_.output_dir, "error.txt"), reason + "\n");
    ProcessResult r;
    r.exit_code = rc;
    return r;
  }

  ProcessResult Interrupted(const std::string& job) const {
    const CommandOutput c = RunCommandCapture({"scancel", job});
    if (c.exit_code != 0) RLOG_WARN("scancel {} failed: {}; cancel the job by hand", job, FirstLine(c.err));
    ProcessResult r;
    r.signaled = true;
    r.signal = InterruptSignal();
    return r;
  }

  const SlurmStageWork& work_;
  const SlurmOptions& options_;
  std::string dir_;
};

}  // namespace

ProcessResult RunOnSlurm(const SlurmStageWork& work, const SlurmOptions& options) {
  RELIGHT_CHECK(!work.argv.empty() && options.shards > 0 && options.cpus_per_task > 0);
  SlurmSubmitter submitter(work, options);
  for (int step = 0; step < work.shard_steps; ++step) {
    TaskSet set;
    set.tag = "step" + std::to_string(step);
    set.label = "pass " + std::to_string(step + 1) + " of " + std::to_string(work.shard_steps) + ", " +
                std::to_string(options.shards) + " shards";
    set.argv = work.argv;
    set.argv.push_back("--shard=$i/" + std::to_string(options.shards));
    set.argv.push_back("--step=" + std::to_string(step));
    set.count = options.shards;
    set.error_file = "shards/step" + std::to_string(step) + "_$i.error.txt";
    const ProcessResult r = submitter.Run(set);
    if (!r.ok()) return r;
  }
  TaskSet whole;
  whole.tag = "whole";
  whole.label = work.shard_steps > 0 ? "gathering the shards" : "one job";
  whole.argv = work.argv;
  whole.error_file = "error.txt";
  return submitter.Run(whole);
}

}  // namespace relight::pipeline
