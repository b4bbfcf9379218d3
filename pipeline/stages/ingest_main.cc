// Stage executable `ingest` (see modules/ingest/ingest.h).
#include "ingest/ingest.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<IngestOptions>(argc, argv, kIngestStage, [](const IngestOptions& options, const StageContext& ctx) {
    return RunIngest(options, {ctx.OptionalInput("synthesize")}, ctx.output_dir);
  });
}
