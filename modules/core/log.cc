#include "core/log.h"

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>

#include <execinfo.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cstring>
#include <memory>

#include "core/error.h"
#include "core/path_text.h"

namespace relight {
namespace {

// `%*` prints "warning: " / "error: " / "debug: " and nothing for info.
class LevelPrefix : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&, spdlog::memory_buf_t& dest) override {
    std::string_view text;
    switch (msg.level) {
      case spdlog::level::warn: text = "warning: "; break;
      case spdlog::level::err:
      case spdlog::level::critical: text = "error: "; break;
      case spdlog::level::debug:
      case spdlog::level::trace: text = "debug: "; break;
      default: break;
    }
    dest.append(text.data(), text.data() + text.size());
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<LevelPrefix>(); }
};

// `%~` prints the message by the path-to-text rule: file names that are not
// UTF-8 appear as `\xHH` in the terminal and the log files alike.
class TextPayload : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&, spdlog::memory_buf_t& dest) override {
    const std::string_view payload(msg.payload.data(), msg.payload.size());
    if (IsValidUtf8(payload)) {
      dest.append(payload.data(), payload.data() + payload.size());
    } else {
      const std::string text = PathText(payload);
      dest.append(text.data(), text.data() + text.size());
    }
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<TextPayload>(); }
};

std::unique_ptr<spdlog::formatter> MakeFormatter(const std::string& pattern) {
  auto formatter = std::make_unique<spdlog::pattern_formatter>();
  formatter->add_flag<LevelPrefix>('*').add_flag<TextPayload>('~').set_pattern(pattern);
  return formatter;
}

spdlog::level::level_enum ToSpd(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return spdlog::level::debug;
    case LogLevel::kInfo: return spdlog::level::info;
    case LogLevel::kWarning: return spdlog::level::warn;
    case LogLevel::kError: return spdlog::level::err;
  }
  return spdlog::level::info;
}

std::shared_ptr<spdlog::sinks::basic_file_sink_mt> g_file_sink;
}  // namespace

LogLevel ParseLogLevel(const std::string& text) {
  if (text == "debug") return LogLevel::kDebug;
  if (text == "info") return LogLevel::kInfo;
  if (text == "warning" || text == "warn") return LogLevel::kWarning;
  if (text == "error") return LogLevel::kError;
  RELIGHT_USER_ERROR() << "unknown log level '" << text << "'; allowed: debug, info, warning, error";
}

void InitLogging(const std::string& name, const std::string& log_file, LogLevel console_level) {
  auto console = std::make_shared<spdlog::sinks::stderr_sink_mt>();
  console->set_level(ToSpd(console_level));
  console->set_formatter(MakeFormatter("%H:%M:%S %n: %*%~"));
  std::vector<spdlog::sink_ptr> sinks{console};
  g_file_sink.reset();
  if (!log_file.empty()) {
    try {
      g_file_sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(log_file, /*truncate=*/false);
    } catch (const spdlog::spdlog_ex& e) {
      RELIGHT_USER_ERROR() << "cannot open log file '" << log_file << "': " << e.what();
    }
    g_file_sink->set_level(spdlog::level::debug);
    g_file_sink->set_formatter(MakeFormatter("%Y-%m-%d %H:%M:%S.%e %*%~"));
    sinks.push_back(g_file_sink);
  }
  auto logger = std::make_shared<spdlog::logger>(name, sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::debug);
  // Every line reaches the file at once: a stage that crashes or is killed
  // keeps in its log everything it printed (a line costs one write call).
  logger->flush_on(spdlog::level::trace);
  spdlog::set_default_logger(logger);
}

void FlushLogs() { spdlog::default_logger()->flush(); }

void LogFileOnly(const std::string& line) {
  if (!g_file_sink) return;
  spdlog::details::log_msg msg(spdlog::default_logger()->name(), spdlog::level::info, line);
  g_file_sink->log(msg);
  g_file_sink->flush();
}

namespace {
int g_crash_fd = -1;            // the log file, opened for the crash handler
const char* g_crash_name = "";  // program name for the crash line

void WriteAll(int fd, const char* text, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, text, n);
    if (w <= 0) return;
    text += w;
    n -= static_cast<size_t>(w);
  }
}

// Appends `text` to the fixed buffer `line` (async-signal-safe).
void Append(char* line, size_t capacity, size_t* n, const char* text) {
  for (; text != nullptr && *text != '\0' && *n + 1 < capacity; ++text) line[(*n)++] = *text;
}

// Async-signal-safe: write(2), sigdescr_np's static table, backtrace_symbols_fd.
void OnCrash(int sig) {
  char line[200];
  size_t n = 0;
  char number[4] = {static_cast<char>('0' + sig / 10 % 10), static_cast<char>('0' + sig % 10), '\0', '\0'};
  Append(line, sizeof(line), &n, g_crash_name);
  Append(line, sizeof(line), &n, ": error: crashed with signal ");
  Append(line, sizeof(line), &n, sig < 10 ? number + 1 : number);
  Append(line, sizeof(line), &n, " (");
  Append(line, sizeof(line), &n, sigdescr_np(sig));
  Append(line, sizeof(line), &n, "); backtrace:\n");
  for (int fd : {2, g_crash_fd}) {
    if (fd < 0) continue;
    WriteAll(fd, line, n);
    void* frames[64];
    ::backtrace_symbols_fd(frames, ::backtrace(frames, 64), fd);
  }
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}
}  // namespace

void InstallCrashHandler(const std::string& name, const std::string& log_file) {
  static std::string name_storage;
  name_storage = name;
  g_crash_name = name_storage.c_str();
  if (g_crash_fd >= 0) ::close(g_crash_fd);
  g_crash_fd = log_file.empty() ? -1 : ::open(log_file.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  void* warm[1];
  ::backtrace(warm, 1);  // loads libgcc now: the first call may allocate, which a crash handler must not
  struct sigaction action {};
  action.sa_handler = OnCrash;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::sigaction(sig, &action, nullptr);
}

}  // namespace relight
