// Running the `colmap` command-line program (Debian's COLMAP 3.8 ships no
// library): one subprocess per step, its stdout/stderr streamed line by line
// into the stage log (never onto the console), with progress parsed from
// COLMAP's own lines.
//
// The process itself is core/process.h's: it dies with the stage.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/external_tools.h"  // ColmapExecutable
#include "core/process.h"

namespace relight {

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
ProcessResult RunColmap(const ColmapCommand& command, const std::function<void(const std::string&)>& on_line = {});

// Parses "[a/b" from COLMAP progress lines such as "Processed file [3/16]"
// after `marker`; returns false when the line does not match.
bool ParseBracketCount(const std::string& line, const std::string& marker, int* done, int* total);

}  // namespace relight
