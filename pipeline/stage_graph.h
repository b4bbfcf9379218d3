// The stage graph: which stages exist, what feeds each of them, and when a
// stage is skipped. Knows option *types* (from each module's `*_options.h`)
// but no algorithm; stages run as separate executables.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight::pipeline {

// Type-erased options of one stage (owns the struct and its OptionTable).
class StageOptionsHolder {
 public:
  virtual ~StageOptionsHolder() = default;
  virtual OptionTable& table() = 0;
  virtual void Check() const = 0;
  // The typed options; T must be the stage's options type.
  template <typename T>
  const T& As() const;
};

template <typename T>
class TypedStageOptions : public StageOptionsHolder {
 public:
  explicit TypedStageOptions(const std::string& section) : table_(MakeOptionTable(section, &options)) {}
  OptionTable& table() override { return table_; }
  void Check() const override { options.Check(); }
  T options;

 private:
  OptionTable table_;
};

template <typename T>
const T& StageOptionsHolder::As() const {
  return static_cast<const TypedStageOptions<T>&>(*this).options;
}

class ResolvedConfig;

// One node of the graph.
struct StageDef {
  StageInfo info;
  // Executable in the same folder as `pipeline`; defaults to info.name.
  std::string executable;
  // Stages whose outputs this one reads, when they are not skipped.
  std::vector<std::string> upstream;
  // Creates the stage's options (defaults).
  std::function<std::unique_ptr<StageOptionsHolder>()> make_options;
  // Why the stage does not run for this config (nullopt: it runs).
  std::function<std::optional<std::string>(const ResolvedConfig&)> skip_reason;
  // Passes of per-photo work the executable can run split into shards (--shard/--step, StageInfo::shardable);
  // null or 0: the stage runs whole.
  std::function<int(const ResolvedConfig&)> shard_steps;

  const std::string& name() const { return info.name; }
  std::string ExecutableName() const { return executable.empty() ? info.name : executable; }
};

// Options of the orchestrator itself (config section `pipeline`).
struct PipelineOptions {
  std::string workspace;  // Folder for the cache, summary and report.
  int threads = 0;        // Worker threads per stage (executor local); 0 uses all cores.
  double min_free_gib = 1.0;  // Warn before a stage when the workspace disk has less free space.
  std::string executor = "local";  // local: stages run here; slurm: as Slurm jobs (pipeline/slurm.h).
  int slurm_shards = 16;           // Tasks per job array of a per-photo pass.
  int slurm_cpus_per_task = 2;     // CPUs each Slurm job asks for (and the stage's threads).
  std::vector<std::string> slurm_sbatch_args;  // Added to every sbatch command.

  void Declare(OptionTable* t) {
    t->Add("workspace", &workspace,
           "Workspace folder (cache, summary.json, report). Empty: ./workspace/<config name>.")
        .OutputPath();
    t->Add("threads", &threads,
           "Worker threads per stage (executor local); 0 uses all cores. Slurm jobs use slurm_cpus_per_task.")
        .Min(0)
        .NotInKey();
    t->Add("min_free_gib", &min_free_gib, "Warn before a stage when the workspace disk has less free space (GiB).")
        .Min(0)
        .NotInKey()
        .Advanced();
    t->Add("executor", &executor,
           "Where stages run. local: as child processes on this machine. slurm: as Slurm batch jobs, the "
           "per-photo passes as job arrays; needs the workspace and the build's bin/ folder on a file "
           "system every node sees. Results and cache keys equal a local run's.")
        .Choices({"local", "slurm"})
        .NotInKey();
    t->Add("slurm_shards", &slurm_shards,
           "Tasks per job array, each doing every N-th photo of a pass. Raise it toward the number of "
           "photos when the cluster has more free CPUs than shards × slurm_cpus_per_task.")
        .Min(1)
        .NotInKey()
        .OnlyWhen("executor", {"slurm"});
    t->Add("slurm_cpus_per_task", &slurm_cpus_per_task,
           "CPUs every job asks for (--cpus-per-task); the stage uses that many threads.")
        .Min(1)
        .NotInKey()
        .OnlyWhen("executor", {"slurm"});
    t->Add("slurm_sbatch_args", &slurm_sbatch_args,
           "Arguments added to every sbatch command, one per list item, e.g. [\"--partition=cpu\", "
           "\"--time=04:00:00\", \"--mem=8G\"].")
        .NotInKey()
        .OnlyWhen("executor", {"slurm"});
  }
  void Check() const {}
};

// A config applied to every stage's options, validated.
class ResolvedConfig {
 public:
  // Validates sections, applies and checks every stage's options. Throws UserError.
  ResolvedConfig(const ConfigDocument& doc, const std::vector<StageDef>& stages);

  const ConfigDocument& document() const { return doc_; }
  const PipelineOptions& pipeline() const { return pipeline_; }
  bool HasSection(const std::string& stage) const { return doc_.HasSection(stage); }
  StageOptionsHolder& options(const std::string& stage) const;
  template <typename T>
  const T& Get(const std::string& stage) const {
    return options(stage).As<T>();
  }

 private:
  ConfigDocument doc_;
  PipelineOptions pipeline_;
  std::unique_ptr<OptionTable> pipeline_table_;
  std::map<std::string, std::unique_ptr<StageOptionsHolder>> options_;
};

// The project's stages, in execution (topological) order.
const std::vector<StageDef>& AllStages();

}  // namespace relight::pipeline
