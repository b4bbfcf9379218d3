#include "sfm/colmap_command.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>

#include "core/error.h"
#include "core/log.h"
#include "core/options.h"
#include "core/timer.h"

namespace relight {

std::string ColmapResult::Describe() const {
  if (signaled) return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  return "exit code " + std::to_string(exit_code);
}

std::string ColmapResult::TailText(int max_lines) const {
  std::string text;
  const int start = std::max(0, static_cast<int>(tail.size()) - max_lines);
  for (int i = start; i < static_cast<int>(tail.size()); ++i) {
    if (!text.empty()) text += " | ";
    text += tail[i];
  }
  return text;
}

ColmapCommand& ColmapCommand::Arg(const std::string& key, const std::string& value) {
  args.emplace_back(key, value);
  return *this;
}

ColmapCommand& ColmapCommand::Arg(const std::string& key, double value) { return Arg(key, CanonicalDouble(value)); }

std::string ColmapCommand::ToString() const {
  std::string s = "colmap " + command;
  for (const auto& [k, v] : args) s += " " + k + " " + v;
  return s;
}

void CheckColmapAvailable() {
  const std::string exe = ColmapExecutable();
  bool found = exe.find('/') != std::string::npos && access(exe.c_str(), X_OK) == 0;
  const char* path = std::getenv("PATH");
  if (!found && exe.find('/') == std::string::npos && path != nullptr) {
    std::string dirs = path;
    size_t start = 0;
    while (!found && start <= dirs.size()) {
      const size_t end = std::min(dirs.find(':', start), dirs.size());
      const std::string candidate = dirs.substr(start, end - start) + "/" + exe;
      found = access(candidate.c_str(), X_OK) == 0;
      start = end + 1;
    }
  }
  if (!found) {
    RELIGHT_USER_ERROR()
        << "cannot run COLMAP ('" << exe
        << "'): install it with `apt-get install colmap` (Debian 12) or set RELIGHT_COLMAP to its path";
  }
}

ColmapResult RunColmap(const ColmapCommand& command, const std::function<void(const std::string&)>& on_line) {
  std::vector<std::string> argv_strings = {ColmapExecutable(), command.command};
  for (const auto& [k, v] : command.args) {
    argv_strings.push_back(k);
    argv_strings.push_back(v);
  }
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  LogFileOnly("$ " + command.ToString());
  int fds[2];
  RELIGHT_CHECK(pipe2(fds, O_CLOEXEC) == 0) << "pipe: " << std::strerror(errno);
  Timer timer;
  const pid_t parent = getpid();
  const pid_t pid = fork();
  RELIGHT_CHECK(pid >= 0) << "fork: " << std::strerror(errno);
  if (pid == 0) {
    // Child: die with the stage, merge stdout and stderr into the pipe.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    const int devnull = open("/dev/null", O_RDONLY);
    if (devnull >= 0) dup2(devnull, STDIN_FILENO);
    setenv("QT_QPA_PLATFORM", "offscreen", 0);
    execvp(argv[0], argv.data());
    std::fprintf(stderr, "cannot execute %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  close(fds[1]);

  ColmapResult result;
  std::deque<std::string> tail;
  FILE* in = fdopen(fds[0], "r");
  RELIGHT_CHECK(in != nullptr) << "fdopen: " << std::strerror(errno);
  std::string line;
  char buffer[4096];
  auto emit = [&](std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
    if (text.empty()) return;
    LogFileOnly("  " + text);
    if (on_line) on_line(text);
    tail.push_back(text);
    if (tail.size() > 12) tail.pop_front();
  };
  while (std::fgets(buffer, sizeof(buffer), in) != nullptr) {
    line += buffer;
    if (!line.empty() && line.back() == '\n') {
      emit(line);
      line.clear();
    }
  }
  emit(line);
  std::fclose(in);

  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    result.signaled = true;
    result.signal = WTERMSIG(status);
  } else {
    result.exit_code = WEXITSTATUS(status);
  }
  result.seconds = timer.Seconds();
  result.tail.assign(tail.begin(), tail.end());
  LogFileOnly("  (" + result.Describe() + ", " + std::to_string(result.seconds) + " s)");
  return result;
}

bool ParseBracketCount(const std::string& line, const std::string& marker, int* done, int* total) {
  const size_t m = line.find(marker);
  if (m == std::string::npos) return false;
  const size_t open = line.find('[', m + marker.size());
  if (open == std::string::npos) return false;
  int a = 0, b = 0;
  if (std::sscanf(line.c_str() + open, "[%d/%d", &a, &b) != 2 || b <= 0) return false;
  *done = a;
  *total = b;
  return true;
}

}  // namespace relight
