#include "core/log.h"

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>

#include <memory>

#include "core/error.h"

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

std::unique_ptr<spdlog::formatter> MakeFormatter(const std::string& pattern) {
  auto formatter = std::make_unique<spdlog::pattern_formatter>();
  formatter->add_flag<LevelPrefix>('*').set_pattern(pattern);
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
  console->set_formatter(MakeFormatter("%H:%M:%S %n: %*%v"));
  std::vector<spdlog::sink_ptr> sinks{console};
  g_file_sink.reset();
  if (!log_file.empty()) {
    try {
      g_file_sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(log_file, /*truncate=*/false);
    } catch (const spdlog::spdlog_ex& e) {
      RELIGHT_USER_ERROR() << "cannot open log file '" << log_file << "': " << e.what();
    }
    g_file_sink->set_level(spdlog::level::debug);
    g_file_sink->set_formatter(MakeFormatter("%Y-%m-%d %H:%M:%S.%e %*%v"));
    sinks.push_back(g_file_sink);
  }
  auto logger = std::make_shared<spdlog::logger>(name, sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::debug);
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

void FlushLogs() { spdlog::default_logger()->flush(); }

void LogFileOnly(const std::string& line) {
  if (!g_file_sink) return;
  spdlog::details::log_msg msg(spdlog::default_logger()->name(), spdlog::level::info, line);
  g_file_sink->log(msg);
}

}  // namespace relight
