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
};

// What a running stage knows besides its options.
struct StageContext {
  std::string output_dir;                     // absolute; exists when the stage starts
  std::map<std::string, std::string> inputs;  // upstream stage name -> its output folder
  int threads = 0;                            // 0: all cores

  bool HasInput(const std::string& name) const { return inputs.count(name) > 0; }
  // The output folder of upstream stage `name`; throws UserError when it was not given.
  const std::string& Input(const std::string& name) const;
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
}  // namespace internal

// The whole `main` of a stage executable:
//   int main(int argc, char** argv) {
//     return relight::StageMain<SynthesizeOptions>(argc, argv, kSynthesizeStage, RunSynthesize);
//   }
template <typename Options>
int StageMain(int argc, char** argv, const StageInfo& info,
              const std::function<void(const Options&, const StageContext&)>& run) {
  Options options;
  OptionTable table = MakeOptionTable(info.name, &options);
  return internal::RunStageProgram(
      argc, argv, info, &table, [&] { options.Check(); }, [&](const StageContext& ctx) { run(options, ctx); });
}

}  // namespace relight
