#include "pipeline/subprocess.h"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <initializer_list>

#include "core/error.h"
#include "pipeline/interrupt.h"

namespace relight::pipeline {

std::string ProcessResult::Describe() const {
  if (signaled) return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  return "exit code " + std::to_string(exit_code);
}

ProcessResult RunProcess(const std::vector<std::string>& argv) {
  RELIGHT_CHECK(!argv.empty());
  if (::access(argv[0].c_str(), X_OK) != 0) {
    RELIGHT_USER_ERROR() << "stage executable '" << argv[0]
                         << "' is missing; build the project first (cmake --build build)";
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) RELIGHT_USER_ERROR() << "cannot start '" << argv[0] << "': " << std::strerror(errno);
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    // A stage must die of the interrupts the orchestrator passes on, even when
    // `pipeline` was started with them ignored (`cmd &` in a script ignores SIGINT).
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::signal(sig, SIG_DFL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before prctl
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  SetInterruptTarget(pid);
  int status = 0;
  struct rusage usage {};
  while (::wait4(pid, &status, 0, &usage) < 0) {
    if (errno != EINTR) {
      SetInterruptTarget(0);
      RELIGHT_USER_ERROR() << "waiting for '" << argv[0] << "' failed: " << std::strerror(errno);
    }
  }
  SetInterruptTarget(0);
  ProcessResult result;
  result.peak_memory_mib = usage.ru_maxrss / 1024.0;  // ru_maxrss is in KiB on Linux
  if (WIFSIGNALED(status)) {
    result.signaled = true;
    result.signal = WTERMSIG(status);
  } else {
    result.exit_code = WEXITSTATUS(status);
  }
  return result;
}

std::string ExecutableDir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

}  // namespace relight::pipeline
