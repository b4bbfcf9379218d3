#include "pipeline/subprocess.h"

#include <unistd.h>

#include <filesystem>

#include "core/error.h"
#include "pipeline/interrupt.h"

namespace relight::pipeline {

ProcessResult RunStageExecutable(const std::vector<std::string>& argv) {
  RELIGHT_CHECK(!argv.empty());
  if (::access(argv[0].c_str(), X_OK) != 0) {
    RELIGHT_USER_ERROR() << "stage executable '" << argv[0]
                         << "' is missing; build the project first (cmake --build build)";
  }
  ProcessOptions options;
  options.default_interrupt_handling = true;
  options.on_start = [](pid_t pid) { SetInterruptTarget(pid); };
  const ProcessResult result = RunProcess(argv, options);
  if (!result.started()) RELIGHT_USER_ERROR() << result.start_error;
  return result;
}

std::string ExecutableDir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

}  // namespace relight::pipeline
