// Runs a stage executable as a child process (core/process.h). The child
// inherits stdout and stderr (so a terminal stays a terminal and progress bars
// work), dies with the orchestrator, and dies of the interrupts the
// orchestrator passes on to it (interrupt.h), so a killed `pipeline` leaves no
// orphan writing into the cache.
#pragma once

#include <string>
#include <vector>

#include "core/process.h"

namespace relight::pipeline {

// Runs the stage executable `argv[0]` with arguments and waits for it. Throws UserError if it is missing or
// cannot start.
ProcessResult RunStageExecutable(const std::vector<std::string>& argv);

// Folder of the running executable (/proc/self/exe).
std::string ExecutableDir();

}  // namespace relight::pipeline
