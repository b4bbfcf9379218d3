// Stage executable `mvs` (see modules/mvs/mvs.h).
#include "mvs/mvs.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<MvsOptions>(argc, argv, kMvsStage, [](const MvsOptions& options, const StageContext& ctx) {
    return RunMvs(options, {ctx.Input("sfm")}, ctx.output_dir, ctx.shard);
  });
}
