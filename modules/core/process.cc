#include "core/process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <deque>

#include "core/external_tools.h"
#include "core/log.h"
#include "core/timer.h"

extern char** environ;

namespace relight {
namespace {

constexpr size_t kTailLines = 20;

// What the child reports through the close-on-exec pipe when it cannot run the program.
struct StartFailure {
  int step = 0;  // 0: chdir, 1: exec
  int error = 0;
};

}  // namespace

std::string ProcessResult::Describe() const {
  if (!started()) return start_error;
  if (signaled) return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  return "exit code " + std::to_string(exit_code);
}

std::string ProcessResult::TailText(int max_lines) const {
  std::string text;
  const size_t start = tail.size() > size_t(max_lines) ? tail.size() - size_t(max_lines) : 0;
  for (size_t i = start; i < tail.size(); ++i) text += (i > start ? " | " : "") + tail[i];
  return text;
}

std::string ProcessResult::DescribeWithOutput(int max_lines) const {
  return tail.empty() ? Describe() : Describe() + ": " + TailText(max_lines);
}

ProcessResult RunProcess(const std::vector<std::string>& argv_in, const ProcessOptions& options) {
  ProcessResult result;
  if (argv_in.empty()) {
    result.start_error = "no program to run";
    return result;
  }
  // Everything the child needs, allocated before fork.
  std::vector<std::string> argv_strings = argv_in;
  std::vector<char*> argv;
  for (auto& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_strings;
  std::vector<char*> envp;
  char** env = environ;
  if (!options.default_env.empty()) {
    for (char** e = environ; *e != nullptr; ++e) env_strings.emplace_back(*e);
    for (const std::string& kv : options.default_env) {
      const std::string name = kv.substr(0, kv.find('='));
      if (std::getenv(name.c_str()) == nullptr) env_strings.push_back(kv);
    }
    for (auto& e : env_strings) envp.push_back(e.data());
    envp.push_back(nullptr);
    env = envp.data();
  }
  const bool lines = options.output == ProcessOptions::Output::kLines;
  const bool capture = options.output == ProcessOptions::Output::kCapture;
  const bool search_path = argv_in[0].find('/') == std::string::npos;
  const char* working_dir = options.working_dir.empty() ? nullptr : options.working_dir.c_str();

  int failure_pipe[2];
  int out_pipe[2] = {-1, -1}, err_pipe[2] = {-1, -1};
  if (pipe2(failure_pipe, O_CLOEXEC) != 0 || ((lines || capture) && pipe2(out_pipe, O_CLOEXEC) != 0) ||
      (capture && pipe2(err_pipe, O_CLOEXEC) != 0)) {
    result.start_error = "cannot create a pipe to run '" + argv_in[0] + "': " + std::strerror(errno);
    return result;
  }
  Timer timer;
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);     // die with the parent
    if (getppid() != parent) _exit(127);  // the parent died before prctl
    if (options.default_interrupt_handling) {
      for (int sig : {SIGINT, SIGTERM, SIGHUP}) signal(sig, SIG_DFL);
    }
    StartFailure failure;
    if (working_dir != nullptr && chdir(working_dir) != 0) {
      failure = {0, errno};
      (void)!write(failure_pipe[1], &failure, sizeof(failure));
      _exit(127);
    }
    if (lines || capture) {
      dup2(out_pipe[1], STDOUT_FILENO);
      dup2(capture ? err_pipe[1] : out_pipe[1], STDERR_FILENO);
      const int devnull = open("/dev/null", O_RDONLY);
      if (devnull >= 0) dup2(devnull, STDIN_FILENO);
    }
    if (search_path) {
      execvpe(argv[0], argv.data(), env);
    } else {
      execve(argv[0], argv.data(), env);
    }
    failure = {1, errno};
    (void)!write(failure_pipe[1], &failure, sizeof(failure));
    _exit(127);
  }
  close(failure_pipe[1]);
  for (int* p : {out_pipe, err_pipe})
    if (p[1] >= 0) close(p[1]);
  if (pid < 0) {
    result.start_error = "cannot start '" + argv_in[0] + "' (fork failed: " + std::strerror(errno) + ")";
    close(failure_pipe[0]);
    for (int* p : {out_pipe, err_pipe})
      if (p[0] >= 0) close(p[0]);
    return result;
  }
  // Empty once exec succeeded (the pipe closed with it); a StartFailure when it did not.
  StartFailure failure;
  ssize_t got = 0;
  while ((got = read(failure_pipe[0], &failure, sizeof(failure))) < 0 && errno == EINTR) {
  }
  close(failure_pipe[0]);
  if (got == ssize_t(sizeof(failure))) {
    result.start_error = failure.step == 0 ? "cannot change to folder '" + options.working_dir + "' to run '" +
                                                 argv_in[0] + "': " + std::strerror(failure.error)
                                           : "cannot execute '" + argv_in[0] + "': " + std::strerror(failure.error);
  } else if (options.on_start) {
    options.on_start(pid);
  }

  if (lines) {
    std::deque<std::string> tail;
    std::string pending;
    char buffer[4096];
    const auto emit = [&](std::string line) {
      while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
      if (line.empty()) return;
      if (options.on_line) options.on_line(line);
      tail.push_back(std::move(line));
      if (tail.size() > kTailLines) tail.pop_front();
    };
    while (true) {
      const ssize_t n = read(out_pipe[0], buffer, sizeof(buffer));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      pending.append(buffer, size_t(n));
      size_t pos;
      while ((pos = pending.find('\n')) != std::string::npos) {
        emit(pending.substr(0, pos));
        pending.erase(0, pos + 1);
      }
    }
    emit(pending);
    close(out_pipe[0]);
    result.tail.assign(tail.begin(), tail.end());
  }
  if (capture) {
    // Both pipes at once, so a child that fills one while we read the other cannot block.
    struct pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
    std::string* sinks[2] = {&result.out, &result.err};
    int open_fds = 2;
    char buffer[4096];
    while (open_fds > 0) {
      if (poll(fds, 2, -1) < 0) {
        if (errno == EINTR) continue;
        break;
      }
      for (int k = 0; k < 2; ++k) {
        if (fds[k].fd < 0 || fds[k].revents == 0) continue;
        const ssize_t n = read(fds[k].fd, buffer, sizeof(buffer));
        if (n > 0) {
          sinks[k]->append(buffer, size_t(n));
        } else if (n == 0 || errno != EINTR) {
          close(fds[k].fd);
          fds[k].fd = -1;
          --open_fds;
        }
      }
    }
    for (const auto& f : fds)
      if (f.fd >= 0) close(f.fd);
  }

  int status = 0;
  struct rusage usage {};
  pid_t waited = 0;
  while ((waited = wait4(pid, &status, 0, &usage)) < 0 && errno == EINTR) {
  }
  if (result.started() && options.on_start) options.on_start(0);
  result.seconds = timer.Seconds();
  result.peak_memory_mib = usage.ru_maxrss / 1024.0;  // ru_maxrss is in KiB on Linux
  if (waited < 0) {
    result.exit_code = -1;  // its status is lost
  } else if (WIFSIGNALED(status)) {
    result.signaled = true;
    result.signal = WTERMSIG(status);
  } else {
    result.exit_code = WEXITSTATUS(status);
  }
  return result;
}

ProcessResult RunColmapProcess(const std::vector<std::string>& args,
                               const std::function<void(const std::string&)>& on_line) {
  std::vector<std::string> argv = {ColmapExecutable()};
  argv.insert(argv.end(), args.begin(), args.end());
  std::string command_line;
  for (const auto& a : argv) command_line += (command_line.empty() ? "" : " ") + a;
  LogFileOnly("$ " + command_line);
  ProcessOptions options;
  options.output = ProcessOptions::Output::kLines;
  options.on_line = [&](const std::string& line) {
    LogFileOnly("  " + line);
    if (on_line) on_line(line);
  };
  options.default_env = {"QT_QPA_PLATFORM=offscreen", "OMP_WAIT_POLICY=passive"};
  const ProcessResult result = RunProcess(argv, options);
  LogFileOnly("  (" + result.Describe() + ", " + std::to_string(result.seconds) + " s)");
  return result;
}

CommandOutput RunCommandCapture(const std::vector<std::string>& argv) {
  ProcessOptions options;
  options.output = ProcessOptions::Output::kCapture;
  ProcessResult r = RunProcess(argv, options);
  CommandOutput c;
  c.exit_code = !r.started() ? 127 : r.signaled ? -1 : r.exit_code;
  c.out = std::move(r.out);
  c.err = r.started() ? std::move(r.err) : r.start_error;
  return c;
}

}  // namespace relight
