// The orchestrator's one signal handler: SIGINT (Ctrl-C), SIGTERM and SIGHUP
// are passed on to the running stage, which stops; the runner then records
// the stage as `interrupted`, keeps every finished result and says how to
// resume. A second signal ends `pipeline` at once.
#pragma once

#include <sys/types.h>

namespace relight::pipeline {

// Installs the handler (idempotent).
void InstallInterruptHandler();
// The signal that asked the run to stop, or 0.
int InterruptSignal();
// Forgets a delivered signal (tests).
void ClearInterrupt();
// The stage process that receives the signal too (0: none).
void SetInterruptTarget(pid_t pid);

}  // namespace relight::pipeline
