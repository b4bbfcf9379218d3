// Runs the stage graph against a workspace with a content-keyed cache.
//
// Layout of a workspace:
//   cache/<stage>/<key>/     one finished (status.json) or resumable run of a stage
//   stages/<stage>           symlink to the entry the current config uses
//   report                   symlink to the current report stage output
//   summary.json             the last `pipeline run`: status, key, seconds per stage
//
// key = SHA-256 over: stage name, stage version, the result-affecting options
// (canonical text, sorted), the keys of the upstream stages that feed it, and
// content digests of raw inputs named by options (photos, meshes, env maps).
// A stage is done only when `status.json` in its folder says so; it is written
// atomically after the executable exits 0. A killed stage is rerun in the same
// folder: stages write every file atomically and per-item stages skip items
// already written, so they resume per image.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/hash.h"
#include "pipeline/stage_graph.h"

namespace relight::pipeline {

// What `pipeline run` should do besides "run what is not cached".
struct RunRequest {
  std::string from;              // rerun this stage and every later one
  std::string only;              // run just this stage (upstream must be cached)
  std::string until;             // stop after this stage
  std::set<std::string> force;   // rerun these even when cached
};

// One stage of a plan or a finished run.
struct StageRecord {
  std::string name;
  std::string key;         // empty when skipped
  // done | cached | failed | interrupted | skipped | stale (plan: cached | missing | skipped);
  // `running` in a summary.json written while the stage runs.
  std::string status;
  double seconds = 0;      // wall time of this run (0 when cached), or of the cached run for `status`
  double peak_memory_mib = 0;  // largest resident set of the stage's process tree, of this or the cached run
  std::string output_dir;  // absolute
  std::string reason;      // why skipped or failed
  std::map<std::string, std::string> upstream;  // upstream stage -> key
  std::string canonical;   // the text that was hashed into `key`
};

class Runner {
 public:
  Runner(const std::vector<StageDef>& stages, const ResolvedConfig& config, std::string workspace,
         std::string bin_dir);

  const std::string& workspace() const { return workspace_; }
  // Keys, skip reasons and cache state of every stage, without running anything.
  std::vector<StageRecord> Plan();
  // Runs the graph; returns the records (also written to summary.json). Throws
  // UserError for bad requests (unknown stage names, missing upstream results).
  // After a SIGINT/SIGTERM/SIGHUP (pipeline/interrupt.h) the running stage is
  // recorded as `interrupted`, later ones as skipped, and nothing else runs.
  std::vector<StageRecord> Run(const RunRequest& request);
  // Removes cache entries: all of them, or all but those the current config uses.
  // Returns the number of entries removed.
  int Clean(bool keep_latest);

  // Folder of a stage's cache entry.
  std::string EntryDir(const std::string& stage, const std::string& key) const;
  // True when `status.json` in `dir` marks a finished run with `key`.
  static bool IsDone(const std::string& dir, const std::string& key);

 private:
  const StageDef& Def(const std::string& name) const;
  void CheckStageName(const std::string& name, const std::string& flag) const;
  bool RunOne(StageRecord* record, bool replace_existing);
  void Publish(const StageRecord& record);
  void WriteSummary(const std::vector<StageRecord>& records) const;

  const std::vector<StageDef>& stages_;
  const ResolvedConfig& config_;
  std::string workspace_;
  std::string bin_dir_;
  DigestCache digests_;
};

// Locks a workspace against concurrent `pipeline run`s (flock); released on destruction.
class WorkspaceLock {
 public:
  explicit WorkspaceLock(const std::string& workspace);
  ~WorkspaceLock();

 private:
  int fd_ = -1;
};

}  // namespace relight::pipeline
