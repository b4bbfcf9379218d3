// Child processes: the one runner behind the stage executables the pipeline starts, the COLMAP commands of sfm
// and mvs, gnuplot for the report's charts and the short Slurm commands.
//
// Written by hand (fork/exec): the stack has no process library, and what the callers need is not in
// posix_spawn: the child must die with its parent (PR_SET_PDEATHSIG), so that a killed stage leaves no
// orphan COLMAP writing into the cache. Everything the child touches is allocated before fork, since a forked
// child of a threaded process must not allocate; a failed exec is reported through a close-on-exec pipe, so it
// is told apart from a program that exits 127.
#pragma once

#include <sys/types.h>

#include <functional>
#include <string>
#include <vector>

namespace relight {

struct ProcessOptions {
  enum class Output {
    kInherit,  // the child writes to our stdout and stderr (a terminal stays a terminal)
    kLines,    // stdout and stderr merged and passed to on_line a line at a time (no end-of-line characters)
    kCapture,  // stdout and stderr kept apart in ProcessResult::out and ::err (short commands)
  };
  Output output = Output::kInherit;
  std::function<void(const std::string&)> on_line;  // kLines: each non-empty line
  // Variables the child gets in addition ("NAME=value"), unless already in our environment.
  std::vector<std::string> default_env;
  std::string working_dir;  // empty: ours
  // The child dies of SIGINT, SIGTERM and SIGHUP even when we were started with them ignored
  // (`cmd &` in a script ignores SIGINT), so an interrupt passed on to it stops it.
  bool default_interrupt_handling = false;
  std::function<void(pid_t)> on_start;  // called with the child's pid once it runs (and with 0 when it ended)
};

struct ProcessResult {
  std::string start_error;  // non-empty: the program could not be started (not found, not executable)
  int exit_code = -1;       // valid when it started and was not signaled
  bool signaled = false;
  int signal = 0;
  double seconds = 0;
  // Largest resident set of the child or of any descendant it waited for [MiB] (wait4's resource usage).
  double peak_memory_mib = 0;
  std::vector<std::string> tail;  // kLines: the last lines of output (at most 20)
  std::string out, err;           // kCapture: everything written to stdout and stderr

  bool started() const { return start_error.empty(); }
  bool ok() const { return started() && !signaled && exit_code == 0; }
  // "exit code 2", "killed by signal 9 (Killed)", "cannot execute 'x': No such file or directory".
  std::string Describe() const;
  // The last `max_lines` lines of output joined with " | ".
  std::string TailText(int max_lines) const;
  // Describe(), then ": " and TailText(max_lines) when there was output.
  std::string DescribeWithOutput(int max_lines) const;
};

// Runs `argv[0]` (looked up on PATH when it has no '/') with the arguments `argv[1..]` and waits for it.
// Never throws for what the child does; a failure to start is in start_error.
ProcessResult RunProcess(const std::vector<std::string>& argv, const ProcessOptions& options = {});

// A short command's output (sbatch, squeue): RunProcess with Output::kCapture; exit code 127 when it could
// not start (err says why), -1 when it was killed.
struct CommandOutput {
  int exit_code = -1;
  std::string out, err;
};
CommandOutput RunCommandCapture(const std::vector<std::string>& argv);

}  // namespace relight
