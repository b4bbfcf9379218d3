// Stage executable `evaluate` (see modules/evaluate/evaluate.h).
#include "evaluate/evaluate.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<EvaluateOptions>(
      argc, argv, kEvaluateStage, [](const EvaluateOptions& options, const StageContext& ctx) {
        auto input = [&](const char* name) { return ctx.HasInput(name) ? ctx.Input(name) : std::string(); };
        EvaluateInputs inputs;
        inputs.ingest_dir = input("ingest");
        inputs.sfm_dir = input("sfm");
        inputs.mesh_dir = input("mesh");
        inputs.linearize_dir = input("linearize");
        inputs.observe_dir = input("observe");
        inputs.visibility_dir = input("visibility");
        inputs.inverse_dir = input("inverse");
        inputs.relight_dir = input("relight");
        return RunEvaluate(options, inputs, ctx.output_dir);
      });
}
