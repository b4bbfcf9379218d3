// Stage executable `linearize` (see modules/radiometry/linearize.h).
#include "radiometry/linearize.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<LinearizeOptions>(argc, argv, kLinearizeStage,
                                     [](const LinearizeOptions& options, const StageContext& ctx) {
                                       return RunLinearize(options, {ctx.Input("ingest")}, ctx.output_dir, ctx.shard);
                                     });
}
