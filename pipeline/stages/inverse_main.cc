// Stage executable `inverse` (see modules/solver/inverse.h).
#include "solver/inverse.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<InverseOptions>(
      argc, argv, kInverseStage, [](const InverseOptions& options, const StageContext& ctx) {
        return RunInverse(options, ctx.HasInput("ingest") ? ctx.Input("ingest") : "", ctx.Input("mesh"),
                          ctx.Input("visibility"), ctx.Input("observe"), ctx.output_dir);
      });
}
