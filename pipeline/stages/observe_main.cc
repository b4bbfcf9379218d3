// Stage executable `observe` (see modules/observe/observe.h).
#include "observe/observe.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<ObserveOptions>(
      argc, argv, kObserveStage, [](const ObserveOptions& options, const StageContext& ctx) {
        return RunObserve(options, {ctx.Input("sfm"), ctx.Input("mesh"), ctx.Input("linearize")}, ctx.output_dir,
                          ctx.shard);
      });
}
