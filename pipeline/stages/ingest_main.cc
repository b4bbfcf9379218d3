// Stage executable `ingest` (see modules/ingest/ingest.h).
#include "core/fs.h"
#include "ingest/ingest.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<IngestOptions>(argc, argv, kIngestStage, [](const IngestOptions& options, const StageContext& ctx) {
    std::string photos = options.images;
    std::string ground_truth = options.ground_truth;
    if (ctx.HasInput("synthesize")) {
      if (!photos.empty()) {
        RELIGHT_USER_ERROR() << "ingest.images is set and the synthesize stage runs too; remove one of them";
      }
      photos = JoinPath(ctx.Input("synthesize"), "images");
      if (ground_truth.empty()) ground_truth = JoinPath(ctx.Input("synthesize"), "ground_truth");
    }
    if (photos.empty()) {
      RELIGHT_USER_ERROR() << "no photos: set ingest.images to the folder of downloaded photos "
                           << "(or add a synthesize: section to render a synthetic collection)";
    }
    RunIngest(options, photos, ground_truth, ctx.output_dir);
  });
}
