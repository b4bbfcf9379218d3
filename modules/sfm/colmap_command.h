// Running the `colmap` command-line program (Debian's COLMAP 3.8 ships no
// library): one subprocess per step, its stdout/stderr streamed line by line
// into the stage log (never onto the console), with progress parsed from
// COLMAP's own lines.
//
// Written by hand: the stack has no process library that streams a child's
// merged output line by line and ties the child's life to ours
// (PR_SET_PDEATHSIG), which a killed pipeline needs to leave no orphan behind.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/external_tools.h"  // ColmapExecutable

namespace relight {

// Outcome of one COLMAP command.
struct ColmapResult {
  int exit_code = -1;     // valid when !signaled
  bool signaled = false;  // killed by a signal (e.g. out of memory)
  int signal = 0;
  double seconds = 0;             // wall time
  std::vector<std::string> tail;  // the last output lines, for error messages
  bool ok() const { return !signaled && exit_code == 0; }
  // "exit code 1", "killed by signal 9".
  std::string Describe() const;
  // The last output lines joined with " | ", for a one-line error.
  std::string TailText(int max_lines = 4) const;
};

// A COLMAP invocation: `colmap <command> --key value ...`.
struct ColmapCommand {
  std::string command;                                    // "feature_extractor"
  std::vector<std::pair<std::string, std::string>> args;  // {"--database_path", "/x/db.db"}
  // Adds `--key value`.
  ColmapCommand& Arg(const std::string& key, const std::string& value);
  ColmapCommand& Arg(const std::string& key, int value) { return Arg(key, std::to_string(value)); }
  ColmapCommand& Arg(const std::string& key, double value);
  ColmapCommand& Arg(const std::string& key, bool value) { return Arg(key, std::string(value ? "1" : "0")); }
  // The command line as one string (for the log).
  std::string ToString() const;
};

// Throws UserError saying how to install COLMAP when it cannot be run.
void CheckColmapAvailable();

// Runs a COLMAP command; every output line goes to the stage log file and to
// `on_line` (may be empty). Does not throw on failure: callers check the
// result *and* the outputs (COLMAP often exits 0 without writing anything).
ColmapResult RunColmap(const ColmapCommand& command, const std::function<void(const std::string&)>& on_line = {});

// Parses "[a/b" from COLMAP progress lines such as "Processed file [3/16]"
// after `marker`; returns false when the line does not match.
bool ParseBracketCount(const std::string& line, const std::string& marker, int* done, int* total);

}  // namespace relight
