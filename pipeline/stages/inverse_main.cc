// Stage executable `inverse` (see modules/solver/inverse.h).
#include <map>

#include "core/error.h"
#include "datasets/ground_truth.h"
#include "solver/inverse.h"
#include "sphere/envmap.h"

namespace relight {
namespace {

// The known lighting and reflectance of inverse.fixed_lighting / fixed_reflectance / start_from_truth, from the
// ground truth ingest carried along: per photo its true map at the solver's resolution in photo units, the true
// materials with the mesh's weights w0… (the true mesh's).
KnownQuantities ReadKnown(const InverseOptions& o, const std::string& ingest_dir, const InverseProblem& problem) {
  KnownQuantities known;
  const GroundTruth truth = GroundTruth::OfIngest(ingest_dir);
  if (!truth.Exists()) {
    RELIGHT_USER_ERROR() << "inverse.fixed_lighting / fixed_reflectance / start_from_truth need ground truth, but "
                         << (truth.dir().empty() ? "no ingest stage output was given"
                                                 : "'" + truth.dir() + "' does not exist")
                         << " (only synthetic scenes and imported data sets have it)";
  }
  if (o.fixed_lighting) {
    std::map<std::string, TruePhotoLighting> by_name;
    for (auto& p : truth.ReadLighting()) by_name[p.name] = std::move(p);
    for (const auto& photo : problem.photos) {
      auto it = by_name.find(photo.name);
      if (it == by_name.end()) {
        RELIGHT_USER_ERROR() << "'" << truth.LightingPath() << "' has no entry for photo '" << photo.name << "'";
      }
      const TruePhotoLighting& p = it->second;
      const Image oct = EnvMap::Load(p.envmap_latlong).ToOctahedral(o.env_resolution, 0);
      // Photo units: exposure × white balance × scene radiance.
      std::vector<float> rgb(oct.pixels.size());
      for (size_t k = 0; k < rgb.size(); ++k)
        rgb[k] = static_cast<float>(oct.pixels[k] * p.exposure * p.white_balance[k % 3]);
      known.lighting_oct_rgb.push_back(std::move(rgb));
    }
    known.has_lighting = true;
  }
  if (o.fixed_reflectance || o.start_from_truth) {
    const ReflectanceModel model = truth.ReadMaterials();
    ReflectanceState& r = known.reflectance;
    r.basis = model.basis;
    r.num_materials = static_cast<int>(model.materials.size());
    for (const auto& m : model.materials)
      for (const auto& c : m.coefficients) r.coefficients.push_back(c);
    r.weights.assign(problem.mesh.num_vertices() * r.num_materials, 0.0f);
    for (int m = 0; m < r.num_materials; ++m) {
      const std::vector<float>* w = problem.mesh.FindProperty("w" + std::to_string(m));
      if (w == nullptr) {
        RELIGHT_USER_ERROR()
            << "inverse.fixed_reflectance / start_from_truth need the ground-truth mesh with material weights "
            << "(property w" << m << "); set mesh.source: ground_truth";
      }
      for (size_t v = 0; v < w->size(); ++v) r.weights[v * r.num_materials + m] = (*w)[v];
    }
    known.has_reflectance = true;
  }
  return known;
}

}  // namespace
}  // namespace relight

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<InverseOptions>(
      argc, argv, kInverseStage, [](const InverseOptions& options, const StageContext& ctx) {
        InverseProblem problem = ReadInverseProblem(ctx.Input("mesh"), ctx.Input("visibility"), ctx.Input("observe"));
        KnownQuantities known;
        if (options.fixed_lighting || options.fixed_reflectance || options.start_from_truth)
          known = ReadKnown(options, ctx.OptionalInput("ingest"), problem);
        return RunInverse(options, problem, known, ctx.output_dir);
      });
}
