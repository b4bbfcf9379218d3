#include "pipeline/interrupt.h"

#include <signal.h>
#include <unistd.h>

#include <initializer_list>


namespace relight::pipeline {
namespace {

volatile sig_atomic_t g_signal = 0;
volatile sig_atomic_t g_child = 0;

void OnSignal(int sig) {
  if (g_signal != 0) {  // a second Ctrl-C: the user insists
    static const char kMessage[] = "\npipeline: second interrupt; stopping now (the cache stays valid)\n";
    (void)!::write(2, kMessage, sizeof(kMessage) - 1);
    if (g_child > 0) ::kill(static_cast<pid_t>(g_child), SIGKILL);
    ::_exit(128 + sig);
  }
  g_signal = sig;
  // Ctrl-C reaches the stage through the terminal's process group already;
  // SIGTERM or SIGHUP sent to `pipeline` alone must be passed on.
  if (g_child > 0) ::kill(static_cast<pid_t>(g_child), sig);
}

}  // namespace

void InstallInterruptHandler() {
  struct sigaction action {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: waitpid returns EINTR and the runner looks at the flag
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(sig, &action, nullptr);
}

int InterruptSignal() { return g_signal; }

void ClearInterrupt() { g_signal = 0; }

void SetInterruptTarget(pid_t pid) {
  g_child = pid;
  // A signal that arrived between fork and now was not passed on.
  if (pid > 0 && g_signal != 0) ::kill(pid, g_signal);
}

}  // namespace relight::pipeline
