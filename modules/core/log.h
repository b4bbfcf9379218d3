// Logging for stages and tools, on spdlog: one console stream (stderr) and,
// for stages, one log file in the stage's cache folder. Messages follow the
// path-to-text rule (core/path_text.h): bytes that are not UTF-8 print as \xHH.
//
// Lines read `12:03:04 synthesize: rendering photo 3/16`; warnings and errors
// carry `warning:` / `error:` so they stand out in plain logs and CI output.
#pragma once

#include <spdlog/spdlog.h>

#include <string>

namespace relight {

enum class LogLevel { kDebug, kInfo, kWarning, kError };

// Parses "debug", "info", "warning", "error"; throws UserError otherwise.
LogLevel ParseLogLevel(const std::string& text);

// Routes logging to stderr (at `console_level`) and, when `log_file` is not
// empty, appends everything at debug level and above to that file. `name`
// prefixes console lines (the stage or tool name).
void InitLogging(const std::string& name, const std::string& log_file, LogLevel console_level);
// Flushes the log file (called before a stage exits).
void FlushLogs();
// Writes a line to the log file only (progress milestones when a bar is on screen).
void LogFileOnly(const std::string& line);
// On a crash (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT) writes "NAME: error:
// crashed with signal N (...)" and a backtrace to stderr and `log_file`, then
// dies of the same signal (the orchestrator reports it). Lines logged before
// are already in the file: every line is flushed as it is written.
void InstallCrashHandler(const std::string& name, const std::string& log_file);

}  // namespace relight

#define RLOG_DEBUG(...) ::spdlog::debug(__VA_ARGS__)
#define RLOG_INFO(...) ::spdlog::info(__VA_ARGS__)
#define RLOG_WARN(...) ::spdlog::warn(__VA_ARGS__)
#define RLOG_ERROR(...) ::spdlog::error(__VA_ARGS__)
