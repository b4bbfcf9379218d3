// Stage executable `mesh` (see modules/meshing/mesh_stage.h).
#include "core/error.h"
#include "datasets/ground_truth.h"
#include "meshing/mesh_stage.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<MeshOptions>(argc, argv, kMeshStage, [](const MeshOptions& options, const StageContext& ctx) {
    MeshInputs inputs;
    inputs.sfm_dir = ctx.OptionalInput("sfm");
    inputs.mvs_dir = ctx.OptionalInput("mvs");
    if (options.source == "ground_truth") {  // the true mesh and occluders, carried along by ingest
      if (!ctx.HasInput("ingest"))
        RELIGHT_USER_ERROR() << "mesh.source is ground_truth: the ingest stage output is needed";
      const GroundTruth truth = GroundTruth::OfIngest(ctx.Input("ingest"));
      if (!truth.HasMesh()) {
        RELIGHT_USER_ERROR() << "mesh.source is ground_truth but '" << truth.MeshPath()
                             << "' does not exist; use a synthetic collection (synthesize: section) or set "
                                "ingest.ground_truth, or choose mesh.source: mvs or file";
      }
      inputs.known_mesh = truth.MeshPath();
      if (truth.HasOccluders()) inputs.known_occluders = truth.OccludersPath();
    }
    return RunMesh(options, inputs, ctx.output_dir);
  });
}
