// Stage executable `mesh` (see modules/meshing/mesh_stage.h).
#include "meshing/mesh_stage.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<MeshOptions>(argc, argv, kMeshStage, [](const MeshOptions& options, const StageContext& ctx) {
    MeshInputs inputs;
    if (ctx.HasInput("ingest")) inputs.ingest_dir = ctx.Input("ingest");
    if (ctx.HasInput("sfm")) inputs.sfm_dir = ctx.Input("sfm");
    if (ctx.HasInput("mvs")) inputs.mvs_dir = ctx.Input("mvs");
    return RunMesh(options, inputs, ctx.output_dir);
  });
}
