// Stage executable `relight` (see modules/relight/relight.h).
#include "relight/relight.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<RelightOptions>(argc, argv, kRelightStage,
                                   [](const RelightOptions& options, const StageContext& ctx) {
                                     RelightInputs inputs;
                                     inputs.ingest_dir = ctx.HasInput("ingest") ? ctx.Input("ingest") : "";
                                     inputs.sfm_dir = ctx.HasInput("sfm") ? ctx.Input("sfm") : "";
                                     inputs.mesh_dir = ctx.HasInput("mesh") ? ctx.Input("mesh") : "";
                                     inputs.inverse_dir = ctx.Input("inverse");
                                     inputs.visibility_dir = ctx.HasInput("visibility") ? ctx.Input("visibility") : "";
                                     return RunRelight(options, inputs, ctx.output_dir, ctx.shard);
                                   });
}
