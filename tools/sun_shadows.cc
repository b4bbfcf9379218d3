// sun_shadows: does each map's fitted sun (lighting.json `sun`, inverse stage) agree with the light and
// shadow the photo shows? For every photo, each vertex it observes is predicted sunlit (facing the sun
// and not occluded towards it, by ray casting on the mesh and its occluders) or in shade, and scored by
// its observed luminance over its recovered albedo's luminance: under the right sun the sunlit vertices
// are the brighter ones. The agreement (correlation of the sun's direct light at each vertex, shadows
// included, with the log of that ratio) of the fitted sun is ranked among the agreement of every
// direction of a 32² octahedral grid above the horizon, and the best-agreeing direction ("the shadows'
// sun") is printed with its angle to the fitted sun. Works on real photos (no ground truth); under
// overcast light there are no shadows to agree with (low irradiance share, low agreement everywhere).
//
//   sun_shadows WORKSPACE
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/stats.h"
#include "evaluate/envmap_metrics.h"
#include "evaluate/leave_one_out.h"
#include "geometry/raycaster.h"
#include "image/color.h"
#include "relight/relight.h"
#include "solver/inverse.h"
#include "sphere/octahedral.h"

namespace {
using namespace relight;

// Pearson correlation, over the photo's vertices, of the direct light a sun in direction `sun` would give
// (cosine to the normal, 0 when the vertex faces away or a ray towards the sun is blocked) with the log of
// the observed shading ratio.
double Agreement(const TriangleMesh& mesh, const RayCaster& caster, const std::vector<uint32_t>& vertices,
                 const std::vector<double>& log_ratio, const Eigen::Vector3d& sun, float offset) {
  const Eigen::Vector3f d = sun.cast<float>();
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (size_t k = 0; k < vertices.size(); ++k) {
    const uint32_t v = vertices[k];
    const Eigen::Vector3f n = mesh.normals[v];
    double direct = std::max(0.0f, n.dot(d));
    if (direct > 0) {
      Ray ray;
      ray.origin = mesh.vertices[v] + offset * n;
      ray.dir = d;
      if (caster.Occluded(ray)) direct = 0;
    }
    const double y = log_ratio[k];
    sx += direct;
    sy += y;
    sxx += direct * direct;
    syy += y * y;
    sxy += direct * y;
  }
  const double m = static_cast<double>(vertices.size());
  const double cov = sxy - sx * sy / m, vx = sxx - sx * sx / m, vy = syy - sy * sy / m;
  return vx > 1e-12 && vy > 1e-12 ? cov / std::sqrt(vx * vy) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Fitted suns against the photos' light and shadow, on a finished workspace", "sun_shadows");
  std::string workspace;
  app.add_option("WORKSPACE", workspace, "Workspace of a finished run (its stages/ links are read)")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    InitLogging("sun_shadows", "", LogLevel::kWarning);
    const std::string stages = JoinPath(workspace, "stages");
    const std::string mesh_dir = JoinPath(stages, "mesh"), inverse = JoinPath(stages, "inverse");
    for (const char* stage : {"mesh", "visibility", "observe", "inverse"})
      if (!std::filesystem::is_regular_file(JoinPath(JoinPath(stages, stage), "status.json")))
        RELIGHT_USER_ERROR() << JoinPath(stages, stage) << " has no finished result; run `pipeline run CONFIG "
                             << "--workspace " << workspace << "` through the inverse stage first";
    const InverseProblem problem =
        LoadInverseProblem(mesh_dir, JoinPath(stages, "visibility"), JoinPath(stages, "observe"));
    const RecoveredModel model = LoadRecoveredModel(inverse, mesh_dir);
    const TriangleMesh& mesh = problem.mesh;
    std::vector<const TriangleMesh*> meshes{&mesh};
    if (!model.occluders.empty()) meshes.push_back(&model.occluders);
    const RayCaster caster(meshes);
    const float offset = static_cast<float>(0.5 * mesh.MeanEdgeLength());
    const std::vector<float>* albedo[3] = {model.mesh.FindProperty("albedo_r"), model.mesh.FindProperty("albedo_g"),
                                           model.mesh.FindProperty("albedo_b")};
    for (const auto* a : albedo)
      if (!a) RELIGHT_USER_ERROR() << JoinPath(inverse, "reflectance.ply") << " has no albedo_r/g/b; rerun inverse";
    const Json lighting = ReadJsonFile(JoinPath(inverse, "lighting.json"));
    std::vector<Eigen::Vector3d> grid;  // candidate directions above the horizon
    for (const Eigen::Vector3d& d : OctTexelDirections(32))
      if (d.z() > 0) grid.push_back(d);
    std::printf("%-28s %6s %6s %9s %9s %8s %9s %9s\n", "photo", "elev", "share", "r(fit)", "rank", "r(max)",
                "elev(max)", "angle");
    std::vector<double> angles, ranks;
    for (const Json& p : lighting.at("photos")) {
      if (!p.contains("sun")) continue;
      const uint32_t photo = p.at("index").get<uint32_t>();
      const auto s = p.at("sun").at("direction_world").get<std::vector<double>>();
      const Eigen::Vector3d sun(s[0], s[1], s[2]);
      std::vector<uint32_t> vertices;
      std::vector<double> ratio;
      for (const Observation& ob : problem.observations.records) {
        if (ob.photo != photo || ob.confidence <= 0) continue;
        const double a = Luminance((*albedo[0])[ob.vertex], (*albedo[1])[ob.vertex], (*albedo[2])[ob.vertex]);
        if (a <= 1e-6) continue;
        vertices.push_back(ob.vertex);
        ratio.push_back(std::log(std::max(1e-6, Luminance(ob.rgb[0], ob.rgb[1], ob.rgb[2]) / a)));
      }
      const double fitted = Agreement(mesh, caster, vertices, ratio, sun, offset);
      double best = -2;
      Eigen::Vector3d best_dir = Eigen::Vector3d::UnitZ();
      int below = 0;
      for (const Eigen::Vector3d& d : grid) {
        const double sep = Agreement(mesh, caster, vertices, ratio, d, offset);
        if (sep < fitted) ++below;
        if (sep > best) {
          best = sep;
          best_dir = d;
        }
      }
      const double rank = double(below) / grid.size();
      const double angle = AngleDeg(sun, best_dir);
      angles.push_back(angle);
      ranks.push_back(rank);
      std::printf("%-28s %6.1f %6.2f %9.3f %9.3f %8.3f %9.1f %9.1f\n", p.at("name").get<std::string>().c_str(),
                  p.at("sun").at("elevation_deg").get<double>(), p.at("sun").at("irradiance_share").get<double>(),
                  fitted, rank, best, std::asin(best_dir.z()) * 180 / M_PI, angle);
    }
    std::printf("median angle to the shadows' sun %.1f deg; median rank of the fitted sun %.3f (%zu photos)\n",
                Median(angles), Median(ranks), angles.size());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sun_shadows: %s\n", e.what());
    return 1;
  }
  return 0;
}
