// Stage executable `sfm` (see modules/sfm/sfm.h).
#include "core/error.h"
#include "datasets/ground_truth.h"
#include "sfm/sfm.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<SfmOptions>(argc, argv, kSfmStage, [](const SfmOptions& options, const StageContext& ctx) {
    std::string given_cameras;
    if (options.mode == "ground_truth") {  // the true cameras, carried along by ingest
      const GroundTruth truth = GroundTruth::OfIngest(ctx.Input("ingest"));
      if (!truth.HasCameras()) {
        RELIGHT_USER_ERROR() << "sfm.mode is ground_truth but " << truth.dir()
                             << " has no cameras.txt/images.txt; set ingest.ground_truth (or use a synthesize: "
                                "section), or set sfm.mode: colmap";
      }
      given_cameras = truth.dir();
    }
    return RunSfm(options, {ctx.Input("ingest"), given_cameras}, ctx.output_dir, ctx.threads);
  });
}
