#include "evaluate/leave_one_out.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"

namespace relight {
namespace fs = std::filesystem;

InverseProblem LoadInverseProblem(const std::string& mesh_dir, const std::string& visibility_dir,
                                  const std::string& observe_dir) {
  const std::string mesh = JoinPath(mesh_dir, "mesh.ply"), vis = JoinPath(visibility_dir, "visibility.bin"),
                    obs = JoinPath(observe_dir, "observations.bin"), photos = JoinPath(observe_dir, "photos.json");
  for (const std::string& path : {mesh, vis, obs, photos}) {
    if (!fs::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "leave-one-photo-out needs '" << path << "', which is missing; rerun the stage that "
                           << "writes it or set evaluate.leave_one_out: never";
    }
  }
  InverseProblem p;
  p.mesh = ReadMesh(mesh);
  if (p.mesh.normals.size() != p.mesh.num_vertices()) p.mesh.ComputeVertexNormals();
  p.visibility = ReadVisibility(vis);
  p.observations = ReadObservations(obs);
  p.photos = ReadObservedPhotos(photos);
  p.footprint_scale = ReadObservedFootprintScale(photos);
  p.mesh_source = ReadMeshSource(mesh_dir);
  if (p.visibility.per_vertex.size() != p.mesh.num_vertices() || p.observations.num_vertices != p.mesh.num_vertices()) {
    RELIGHT_USER_ERROR() << "'" << mesh << "' (" << p.mesh.num_vertices() << " vertices), '" << vis << "' ("
                         << p.visibility.per_vertex.size() << ") and '" << obs << "' (" << p.observations.num_vertices
                         << ") disagree; rerun from the mesh stage";
  }
  return p;
}

ObservationSet RestrictObservations(const ObservationSet& all, const std::vector<uint32_t>& photos) {
  std::vector<int> new_index(all.num_photos, -1);
  for (size_t k = 0; k < photos.size(); ++k) new_index[photos[k]] = static_cast<int>(k);
  ObservationSet out;
  out.num_photos = static_cast<uint32_t>(photos.size());
  out.num_vertices = all.num_vertices;
  for (const Observation& o : all.records) {
    if (new_index[o.photo] < 0) continue;
    Observation r = o;
    r.photo = static_cast<uint32_t>(new_index[o.photo]);
    out.records.push_back(r);
  }
  // Keep the file's order: by photo, then vertex.
  std::stable_sort(out.records.begin(), out.records.end(), [](const Observation& a, const Observation& b) {
    return a.photo != b.photo ? a.photo < b.photo : a.vertex < b.vertex;
  });
  return out;
}

LeaveOneOutFit LeaveOneOut(InverseProblem* problem, const InverseOptions& options, uint32_t photo, int max_iterations) {
  Timer timer;
  const uint32_t n = problem->observations.num_photos;
  RELIGHT_CHECK_LT(photo, n);
  if (n < 2) RELIGHT_USER_ERROR() << "leave-one-photo-out needs at least 2 photos; the collection has " << n;
  LeaveOneOutFit fit;
  fit.photo = photo;

  InverseProblem sub;
  sub.mesh = problem->mesh;
  sub.footprint_scale = problem->footprint_scale;
  sub.mesh_source = problem->mesh_source;
  sub.visibility = std::move(problem->visibility);
  std::vector<uint32_t> others;
  for (uint32_t i = 0; i < n; ++i)
    if (i != photo) others.push_back(i);
  try {
    // Reflectance from the other photos.
    sub.observations = RestrictObservations(problem->observations, others);
    InverseOptions o = options;
    o.fixed_lighting = o.fixed_reflectance = false;
    if (max_iterations > 0) o.max_iterations = std::min(o.max_iterations, max_iterations);
    InverseResult without = SolveInverse(sub, o);
    fit.reflectance = without.reflectance;
    fit.reflectance_summary = without.summary;

    // Photo i's lighting with that reflectance held fixed, from all of its observations.
    sub.observations = RestrictObservations(problem->observations, {photo});
    if (sub.observations.records.empty()) {
      RELIGHT_USER_ERROR() << "photo '" << problem->photos[photo].name << "' has no observations; it cannot be "
                           << "scored by leave-one-photo-out";
    }
    KnownQuantities known;
    known.reflectance = fit.reflectance;
    known.has_reflectance = true;
    InverseOptions lo = options;
    lo.fixed_lighting = false;
    lo.fixed_reflectance = true;
    lo.holdout_fraction = 0;
    const InverseResult lit = SolveInverse(sub, lo, &known);
    const int size = lo.lighting_basis == "haar" ? lo.env_resolution : 32;
    const std::vector<float> rgb = lit.lighting.OctahedralRgb(0, size);
    fit.lighting_oct = Image(size, size, 3);
    for (size_t k = 0; k < rgb.size(); ++k) fit.lighting_oct.pixels[k] = std::max(0.0f, rgb[k]);
  } catch (...) {
    problem->visibility = std::move(sub.visibility);
    throw;
  }
  problem->visibility = std::move(sub.visibility);
  fit.seconds = timer.Seconds();
  return fit;
}

std::vector<uint32_t> SpreadPhotos(uint32_t num_photos, int max_photos) {
  std::vector<uint32_t> out;
  if (max_photos <= 0 || uint32_t(max_photos) >= num_photos) {
    for (uint32_t i = 0; i < num_photos; ++i) out.push_back(i);
    return out;
  }
  for (int k = 0; k < max_photos; ++k) {
    const uint32_t i = static_cast<uint32_t>(std::floor((k + 0.5) * num_photos / max_photos));
    if (out.empty() || out.back() != i) out.push_back(std::min(i, num_photos - 1));
  }
  return out;
}

}  // namespace relight
