// Stage executable `report` (see modules/report/report.h).
#include "report/report.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<ReportOptions>(argc, argv, kReportStage, [](const ReportOptions& options, const StageContext& ctx) {
    RunReport(options, ctx.inputs, ctx.output_dir);
  });
}
