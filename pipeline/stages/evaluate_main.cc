// Stage executable `evaluate` (see modules/evaluate/evaluate.h).
#include "evaluate/evaluate.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<EvaluateOptions>(argc, argv, kEvaluateStage,
                                    [](const EvaluateOptions& options, const StageContext& ctx) {
                                      EvaluateInputs inputs;
                                      inputs.ingest_dir = ctx.OptionalInput("ingest");
                                      inputs.sfm_dir = ctx.OptionalInput("sfm");
                                      inputs.mesh_dir = ctx.OptionalInput("mesh");
                                      inputs.linearize_dir = ctx.OptionalInput("linearize");
                                      inputs.observe_dir = ctx.OptionalInput("observe");
                                      inputs.visibility_dir = ctx.OptionalInput("visibility");
                                      inputs.inverse_dir = ctx.OptionalInput("inverse");
                                      inputs.relight_dir = ctx.OptionalInput("relight");
                                      return RunEvaluate(options, inputs, ctx.output_dir);
                                    });
}
