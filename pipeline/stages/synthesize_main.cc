// Stage executable `synthesize` (see modules/synth/synthesize.h).
#include "synth/synthesize.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<SynthesizeOptions>(
      argc, argv, kSynthesizeStage,
      [](const SynthesizeOptions& options, const StageContext& ctx) { return RunSynthesize(options, ctx.output_dir); });
}
