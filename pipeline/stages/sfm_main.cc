// Stage executable `sfm` (see modules/sfm/sfm.h).
#include "sfm/sfm.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<SfmOptions>(argc, argv, kSfmStage, [](const SfmOptions& options, const StageContext& ctx) {
    return RunSfm(options, ctx.Input("ingest"), ctx.output_dir, ctx.threads);
  });
}
