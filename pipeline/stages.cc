// The project's stage graph, in execution order. Each entry names the stage's
// options type (from its module's *_options.h, header-only), the stages whose
// outputs it reads (`--input NAME=DIR`), and when it is skipped. CMake defines
// RELIGHT_HAVE_<STAGE> for every stage whose module and executable are in the
// tree (pipeline/CMakeLists.txt), so the graph builds at every step.
#include "pipeline/stage_graph.h"

#ifdef RELIGHT_HAVE_SYNTHESIZE
#include "synth/synthesize_options.h"
#endif
#include "ingest/ingest_options.h"
#ifdef RELIGHT_HAVE_SFM
#include "sfm/sfm_options.h"
#endif
#ifdef RELIGHT_HAVE_MVS
#include "mvs/mvs_options.h"
#endif
#ifdef RELIGHT_HAVE_MESH
#include "meshing/mesh_options.h"
#endif
#ifdef RELIGHT_HAVE_LINEARIZE
#include "radiometry/linearize_options.h"
#endif
#ifdef RELIGHT_HAVE_VISIBILITY
#include "visibility/visibility_options.h"
#endif
#ifdef RELIGHT_HAVE_OBSERVE
#include "observe/observe_options.h"
#endif
#ifdef RELIGHT_HAVE_INVERSE
#include "solver/inverse_options.h"
#endif
#ifdef RELIGHT_HAVE_RELIGHT
#include "relight/relight_options.h"
#endif
#ifdef RELIGHT_HAVE_EVALUATE
#include "evaluate/evaluate_options.h"
#endif
#ifdef RELIGHT_HAVE_REPORT
#include "report/report_options.h"
#endif

namespace relight::pipeline {
namespace {

template <typename Options>
std::function<std::unique_ptr<StageOptionsHolder>()> Make(const StageInfo& info) {
  return [name = info.name] { return std::make_unique<TypedStageOptions<Options>>(name); };
}

using SkipFn = std::function<std::optional<std::string>(const ResolvedConfig&)>;
using ShardFn = std::function<int(const ResolvedConfig&)>;
// A stage whose per-photo work is one pass.
ShardFn OnePass() {
  return [](const ResolvedConfig&) { return 1; };
}

}  // namespace

const std::vector<StageDef>& AllStages() {
  static const std::vector<StageDef> stages = [] {
    std::vector<StageDef> s;
#ifdef RELIGHT_HAVE_SYNTHESIZE
    s.push_back({kSynthesizeStage, "", {}, Make<SynthesizeOptions>(kSynthesizeStage),
                 SkipFn([](const ResolvedConfig& c) -> std::optional<std::string> {
                   if (c.HasSection("synthesize")) return std::nullopt;
                   return "the config has no synthesize: section (photos come from ingest.images)";
                 }),
                 nullptr});
#endif
    s.push_back({kIngestStage, "", {"synthesize"}, Make<IngestOptions>(kIngestStage), nullptr, nullptr});
#ifdef RELIGHT_HAVE_SFM
    s.push_back({kSfmStage, "", {"ingest"}, Make<SfmOptions>(kSfmStage), nullptr, nullptr});
#endif
#ifdef RELIGHT_HAVE_MVS
    s.push_back({kMvsStage, "", {"sfm"}, Make<MvsOptions>(kMvsStage),
                 SkipFn([](const ResolvedConfig& c) -> std::optional<std::string> {
#ifdef RELIGHT_HAVE_MESH
                   const std::string& source = c.Get<MeshOptions>("mesh").source;
                   if (source != "mvs") return "mesh.source is '" + source + "', so no dense reconstruction is needed";
#endif
                   return std::nullopt;
                 }),
                 ShardFn([](const ResolvedConfig& c) { return MvsShardSteps(c.Get<MvsOptions>("mvs")); })});
#endif
#ifdef RELIGHT_HAVE_MESH
    s.push_back({kMeshStage, "", {"ingest", "sfm", "mvs"}, Make<MeshOptions>(kMeshStage), nullptr, nullptr});
#endif
#ifdef RELIGHT_HAVE_LINEARIZE
    s.push_back({kLinearizeStage, "", {"ingest"}, Make<LinearizeOptions>(kLinearizeStage), nullptr, OnePass()});
#endif
#ifdef RELIGHT_HAVE_VISIBILITY
    s.push_back({kVisibilityStage, "", {"mesh"}, Make<VisibilityOptions>(kVisibilityStage), nullptr, nullptr});
#endif
#ifdef RELIGHT_HAVE_OBSERVE
    s.push_back({kObserveStage, "", {"sfm", "mesh", "linearize"}, Make<ObserveOptions>(kObserveStage), nullptr,
                 OnePass()});
#endif
#ifdef RELIGHT_HAVE_INVERSE
    s.push_back({kInverseStage, "", {"ingest", "mesh", "visibility", "observe"}, Make<InverseOptions>(kInverseStage),
                 nullptr, nullptr});
#endif
#ifdef RELIGHT_HAVE_RELIGHT
    s.push_back({kRelightStage, "", {"ingest", "sfm", "mesh", "visibility", "inverse"},
                 Make<RelightOptions>(kRelightStage), nullptr, OnePass()});
#endif
#ifdef RELIGHT_HAVE_EVALUATE
    s.push_back({kEvaluateStage,
                 "",
                 {"ingest", "sfm", "mesh", "linearize", "observe", "visibility", "inverse", "relight"},
                 Make<EvaluateOptions>(kEvaluateStage),
                 nullptr, nullptr});
#endif
#ifdef RELIGHT_HAVE_REPORT
    s.push_back({kReportStage,
                 "",
                 {"ingest", "sfm", "mesh", "linearize", "observe", "inverse", "relight", "evaluate"},
                 Make<ReportOptions>(kReportStage),
                 nullptr, nullptr});
#endif
    return s;
  }();
  return stages;
}

}  // namespace relight::pipeline
