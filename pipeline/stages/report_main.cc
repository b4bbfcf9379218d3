// Stage executable `report` (see modules/report/report.h).
#include "report/report.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<ReportOptions>(argc, argv, kReportStage, [](const ReportOptions& options, const StageContext& ctx) {
    auto input = [&](const char* name) { return ctx.HasInput(name) ? ctx.Input(name) : std::string(); };
    ReportInputs inputs;
    inputs.ingest_dir = input("ingest");
    inputs.sfm_dir = input("sfm");
    inputs.mesh_dir = input("mesh");
    inputs.linearize_dir = input("linearize");
    inputs.observe_dir = input("observe");
    inputs.inverse_dir = input("inverse");
    inputs.relight_dir = input("relight");
    inputs.evaluate_dir = input("evaluate");
    return RunReport(options, inputs, ctx.output_dir);
  });
}
