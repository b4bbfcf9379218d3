// Stage executable `report` (see modules/report/report.h).
#include "report/report.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<ReportOptions>(argc, argv, kReportStage, [](const ReportOptions& options, const StageContext& ctx) {
    ReportInputs inputs;
    inputs.ingest_dir = ctx.OptionalInput("ingest");
    inputs.sfm_dir = ctx.OptionalInput("sfm");
    inputs.mesh_dir = ctx.OptionalInput("mesh");
    inputs.linearize_dir = ctx.OptionalInput("linearize");
    inputs.observe_dir = ctx.OptionalInput("observe");
    inputs.inverse_dir = ctx.OptionalInput("inverse");
    inputs.relight_dir = ctx.OptionalInput("relight");
    inputs.evaluate_dir = ctx.OptionalInput("evaluate");
    return RunReport(options, inputs, ctx.output_dir);
  });
}
