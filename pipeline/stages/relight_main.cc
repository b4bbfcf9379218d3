// Stage executable `relight` (see modules/relight/relight.h).
#include "core/error.h"
#include "datasets/ground_truth.h"
#include "datasets/ground_truth_frame.h"
#include "relight/relight.h"

namespace relight {
namespace {

// The ground truth's held-out views under its held-out maps (relight/index.json of the folder ingest carried
// along), both brought into the model's frame (datasets/ground_truth_frame.h); or notes why there are none.
HeldoutViews TrueHeldoutViews(const std::string& ingest_dir, const std::string& sfm_dir) {
  HeldoutViews h;
  const GroundTruth truth = GroundTruth::OfIngest(ingest_dir);
  if (!truth.HasHeldout()) {
    h.notes.push_back("no held-out views: the ground truth has no relight/index.json");
    return h;
  }
  const GroundTruthFrame frame = RelateToGroundTruth(sfm_dir, truth);
  if (!frame.available) {
    h.notes.push_back("held-out views not rendered: " + frame.reason);
    return h;
  }
  h.frame_method = frame.method;
  h.cameras = frame.CamerasToModel(truth.ReadHeldoutCameras());
  const TrueHeldout heldout = truth.ReadHeldout();
  for (const auto& e : heldout.envmaps) h.envmaps[e.name] = frame.EnvToModel(EnvMap::Load(e.latlong));
  for (const auto& r : heldout.renders) {
    if (h.cameras.FindImage(r.view) == nullptr || !h.envmaps.count(r.envmap)) {
      RELIGHT_USER_ERROR() << "'" << heldout.index << "' names view '" << r.view << "' or map '" << r.envmap
                           << "' that its cameras/envmaps do not have; regenerate the ground truth";
    }
    h.renders.emplace_back(r.view, r.envmap);
  }
  return h;
}

}  // namespace
}  // namespace relight

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<RelightOptions>(
      argc, argv, kRelightStage, [](const RelightOptions& options, const StageContext& ctx) {
        RelightInputs inputs;
        inputs.sfm_dir = ctx.OptionalInput("sfm");
        inputs.mesh_dir = ctx.OptionalInput("mesh");
        inputs.inverse_dir = ctx.Input("inverse");
        inputs.visibility_dir = ctx.OptionalInput("visibility");
        if (options.heldout) inputs.heldout = TrueHeldoutViews(ctx.OptionalInput("ingest"), inputs.sfm_dir);
        return RunRelight(options, inputs, ctx.output_dir, ctx.shard);
      });
}
