// Runs a stage executable as a child process. The child inherits stdout and
// stderr (so a terminal stays a terminal and progress bars work) and dies with
// the orchestrator (PR_SET_PDEATHSIG), so a killed `pipeline` leaves no orphan
// writing into the cache.
#pragma once

#include <string>
#include <vector>

namespace relight::pipeline {

struct ProcessResult {
  int exit_code = -1;  // valid when !signaled
  bool signaled = false;
  int signal = 0;
  // Largest resident set of the child or of any descendant it waited for (COLMAP runs under sfm and mvs)
  // [MiB], from wait4's resource usage.
  double peak_memory_mib = 0;
  bool ok() const { return !signaled && exit_code == 0; }
  // "exit code 2", "killed by signal 9 (Killed)".
  std::string Describe() const;
};

// Runs `argv[0]` with arguments, waits for it. Throws UserError if it cannot start.
ProcessResult RunProcess(const std::vector<std::string>& argv);

// Output of a short command (sbatch, squeue): exit code (127: could not start), stdout, stderr.
struct CommandOutput {
  int exit_code = -1;
  std::string out, err;
};
// Runs `argv` (looked up on PATH, no shell) and collects its output. Never throws.
CommandOutput RunCommandCapture(const std::vector<std::string>& argv);

// Folder of the running executable (/proc/self/exe).
std::string ExecutableDir();

}  // namespace relight::pipeline
