// Stage executable `ingest` (see modules/ingest/ingest.h).
#include "core/fs.h"
#include "datasets/diligent.h"
#include "ingest/ingest.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<IngestOptions>(argc, argv, kIngestStage, [](const IngestOptions& given, const StageContext& ctx) {
    IngestOptions options = given;
    std::string photos = options.images;
    std::string ground_truth = options.ground_truth;
    if (ctx.HasInput("synthesize")) {
      if (!photos.empty()) {
        RELIGHT_USER_ERROR() << "ingest.images is set and the synthesize stage runs too; remove one of them";
      }
      photos = JoinPath(ctx.Input("synthesize"), "images");
      if (ground_truth.empty()) ground_truth = JoinPath(ctx.Input("synthesize"), "ground_truth");
    }
    if (options.format == "diligent") {
      // A DiLiGenT object folder becomes a scene (photos + ground truth) first.
      if (photos.empty()) RELIGHT_USER_ERROR() << "ingest.format = diligent needs ingest.images (the object folder)";
      const std::string scene = JoinPath(ctx.output_dir, "import");
      ImportDiligent(photos, scene, {options.diligent_sphere_subdivisions, 100.0});
      photos = JoinPath(scene, "images");
      if (ground_truth.empty()) ground_truth = JoinPath(scene, "ground_truth");
      // Calibrated photometric data: one view under different known lights. The photos are
      // nearly achromatic on a dark background and may look alike; every one of them is used.
      options.drop_grayscale = false;
      options.drop_duplicates = false;
    }
    if (photos.empty()) {
      RELIGHT_USER_ERROR() << "no photos: set ingest.images to the folder of downloaded photos "
                           << "(or add a synthesize: section to render a synthetic collection)";
    }
    RunIngest(options, photos, ground_truth, ctx.output_dir);
  });
}
