// The contract between the orchestrator and a stage executable.
//
// A stage is a separate program (build/bin/<stage>) that reads its options
// from a YAML config (its own section) plus `--set` overrides, reads upstream
// outputs from `--input NAME=DIR` folders, and writes everything into
// `--output DIR`. It never decides whether it is "done": the orchestrator
// writes `status.json` after the program exits 0 and its outputs are in place.
//
//   synthesize --config configs/synthetic_tiny.yaml --output /tmp/synth
//   linearize --config c.yaml --input ingest=/ws/cache/ingest/<key> --output /tmp/lin
//
// Exit codes: 0 success; 2 the user's input is wrong (a one-line reason is in
// `<output>/error.txt` and on stderr); 3 internal error (a bug).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/config.h"
#include "core/error.h"
#include "core/options.h"

namespace relight {

// Static description of a stage.
struct StageInfo {
  std::string name;         // "synthesize"; also the config section and executable name
  std::string description;  // one line, shown by `pipeline stages` and --help
  int version = 1;          // bumped when the algorithm changes results; enters the cache key
  // Accepts --shard/--step: its per-photo work can be split over processes (pipeline.executor: slurm).
  bool shardable = false;
};

// One process's part of a stage's per-item work (photos, views), when the work is split over a job array.
// Step `step` of the stage's barrier-separated passes, items with index % count == index. A sharded run
// writes the per-item files of its items and nothing else; a later unsharded run of the same output folder
// finds every item done and writes the stage's summary outputs.
struct ShardSpec {
  int index = 0;
  int count = 0;  // 0: not sharded, the whole stage
  int step = 0;

  bool active() const { return count > 0; }
  bool Owns(size_t item) const { return count == 0 || static_cast<int>(item % count) == index; }
  // "step 0, shard 3 of 8".
  std::string Describe() const;
};

// What a running stage knows besides its options.
struct StageContext {
  std::string output_dir;                     // absolute; exists when the stage starts
  std::map<std::string, std::string> inputs;  // upstream stage name -> its output folder
  int threads = 0;                            // 0: all cores
  ShardSpec shard;                            // inactive unless --shard was given

  bool HasInput(const std::string& name) const { return inputs.count(name) > 0; }
  // The output folder of upstream stage `name`; throws UserError when it was not given.
  const std::string& Input(const std::string& name) const;
  // The output folder of upstream stage `name`, or "" when it was not given (an optional input).
  std::string OptionalInput(const std::string& name) const { return HasInput(name) ? Input(name) : std::string(); }
  // Path of a file in the output folder.
  std::string OutputPath(const std::string& relative) const;
};

// Exit codes shared by stages and the orchestrator.
inline constexpr int kExitOk = 0;
inline constexpr int kExitUserError = 2;
inline constexpr int kExitInternalError = 3;

namespace internal {
using StageRunFn = std::function<void(const StageContext&)>;
// Non-template part of StageMain: argument parsing, logging, error handling.
int RunStageProgram(int argc, char** argv, const StageInfo& info, OptionTable* table,
                    const std::function<void()>& check, const StageRunFn& run);
void LogBriefReport(const std::string& report);
}  // namespace internal

// The whole `main` of a stage executable. `run(options, ctx)` reads the upstream folders of `ctx` into the
// stage's `XxxInputs` and calls its `RunXxx(options, inputs, ctx.output_dir[, ctx.shard])`, returning the
// stage's summary, whose `BriefReport()` (one paragraph) is logged when the stage finishes (not after a
// shard's part of it, which has no summary):
//   int main(int argc, char** argv) {
//     return relight::StageMain<VisibilityOptions>(argc, argv, kVisibilityStage,
//         [](const VisibilityOptions& o, const StageContext& ctx) {
//           return RunVisibility(o, {ctx.Input("mesh")}, ctx.output_dir);
//         });
//   }
template <typename Options, typename Run>
int StageMain(int argc, char** argv, const StageInfo& info, const Run& run) {
  Options options;
  OptionTable table = MakeOptionTable(info.name, &options);
  return internal::RunStageProgram(
      argc, argv, info, &table, [&] { options.Check(); },
      [&](const StageContext& ctx) {
        const auto summary = run(std::as_const(options), ctx);
        if (!ctx.shard.active()) internal::LogBriefReport(summary.BriefReport());
      });
}

}  // namespace relight
