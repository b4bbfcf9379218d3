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
  for (const std::string& path : {JoinPath(mesh_dir, "mesh.ply"), JoinPath(visibility_dir, "visibility.bin"),
                                  JoinPath(observe_dir, "observations.bin"), JoinPath(observe_dir, "photos.json")}) {
    if (!fs::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "leave-one-photo-out needs '" << path << "', which is missing; rerun the stage that "
                           << "writes it or set evaluate.leave_one_out: never";
    }
  }
  return ReadInverseProblem(mesh_dir, visibility_dir, observe_dir);
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

ReflectanceState ReflectanceStateOf(const TriangleMesh& mesh, const ReflectanceModel& model) {
  ReflectanceState r;
  r.basis = model.basis;
  r.num_materials = static_cast<int>(model.materials.size());
  const int b_count = r.num_lobes();
  r.lobe_enabled.assign(b_count, 0);
  for (const Material& m : model.materials) {
    RELIGHT_CHECK_EQ(static_cast<int>(m.coefficients.size()), b_count);
    for (int b = 0; b < b_count; ++b) {
      r.coefficients.push_back(m.coefficients[b]);
      if (m.coefficients[b].maxCoeff() > 0) r.lobe_enabled[b] = 1;
    }
  }
  r.weights.assign(mesh.num_vertices() * r.num_materials, 0.0f);
  for (int m = 0; m < r.num_materials; ++m) {
    const std::vector<float>* w = mesh.FindProperty("w" + std::to_string(m));
    if (w == nullptr || w->size() != mesh.num_vertices()) {
      RELIGHT_USER_ERROR() << "the recovered model has no per-vertex weight w" << m
                           << " of its materials; rerun the inverse stage";
    }
    for (size_t v = 0; v < w->size(); ++v) r.weights[v * r.num_materials + m] = (*w)[v];
  }
  return r;
}

Image FitLighting(const InverseProblem& one_photo, const InverseOptions& options, const ReflectanceState& reflectance,
                  double* rmse) {
  RELIGHT_CHECK_EQ(one_photo.observations.num_photos, 1u);
  KnownQuantities known;
  known.reflectance = reflectance;
  known.has_reflectance = true;
  InverseOptions lo = options;
  lo.fixed_lighting = lo.start_from_truth = false;
  lo.fixed_reflectance = true;
  lo.holdout_fraction = 0;
  lo.map_resolution = "off";
  const InverseResult lit = SolveInverse(one_photo, lo, &known);
  if (rmse != nullptr && !lit.summary.iterations.empty()) *rmse = lit.summary.iterations.back().train_rmse;
  const int size = lo.lighting_basis == "haar" ? lo.env_resolution : 32;
  const std::vector<float> rgb = lit.lighting.OctahedralRgb(0, size);
  Image oct(size, size, 3);
  for (size_t k = 0; k < rgb.size(); ++k) oct.pixels[k] = std::max(0.0f, rgb[k]);
  return oct;
}

LeaveOneOutFit LeaveOneOut(InverseProblem* problem, const InverseOptions& options, uint32_t photo, int max_iterations,
                           const ReflectanceState* warm_start) {
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
  sub.scratch_dir = problem->scratch_dir;
  sub.visibility = std::move(problem->visibility);
  std::vector<uint32_t> others;
  for (uint32_t i = 0; i < n; ++i)
    if (i != photo) others.push_back(i);
  try {
    // Reflectance from the other photos.
    sub.observations = RestrictObservations(problem->observations, others);
    InverseOptions o = options;
    o.fixed_lighting = o.fixed_reflectance = o.start_from_truth = false;
    o.map_resolution = "off";
    if (max_iterations > 0) o.max_iterations = std::min(o.max_iterations, max_iterations);
    KnownQuantities start;
    if (warm_start != nullptr) {
      RELIGHT_CHECK_EQ(warm_start->weights.size(), problem->mesh.num_vertices() * warm_start->num_materials);
      start.reflectance = *warm_start;
      start.has_reflectance = true;
      o.coarse_iterations = 0;  // the start is already fine
    }
    InverseResult without = SolveInverse(sub, o, warm_start != nullptr ? &start : nullptr);
    fit.reflectance = without.reflectance;
    fit.reflectance_summary = without.summary;

    // Photo i's lighting with that reflectance held fixed, from all of its observations.
    sub.observations = RestrictObservations(problem->observations, {photo});
    if (sub.observations.records.empty()) {
      RELIGHT_USER_ERROR() << "photo '" << problem->photos[photo].name << "' has no observations; it cannot be "
                           << "scored by leave-one-photo-out";
    }
    fit.lighting_oct = FitLighting(sub, options, fit.reflectance, &fit.photo_rmse);
  } catch (...) {
    problem->visibility = std::move(sub.visibility);
    throw;
  }
  problem->visibility = std::move(sub.visibility);
  fit.seconds = timer.Seconds();
  return fit;
}

std::vector<std::vector<uint32_t>> LeaveOutGroups(const std::vector<uint32_t>& scored, uint32_t num_photos) {
  const size_t size = std::max<size_t>(1, num_photos / 5);
  const size_t groups = (scored.size() + size - 1) / size;
  std::vector<std::vector<uint32_t>> out(groups);
  for (size_t k = 0; k < scored.size(); ++k) out[k % groups].push_back(scored[k]);
  return out;
}

ReflectanceState SolveWithout(InverseProblem* problem, const InverseOptions& options,
                              const std::vector<uint32_t>& left_out) {
  const uint32_t n = problem->observations.num_photos;
  std::vector<char> out(n, 0);
  for (uint32_t i : left_out) {
    RELIGHT_CHECK_LT(i, n);
    out[i] = 1;
  }
  std::vector<uint32_t> kept;
  for (uint32_t i = 0; i < n; ++i)
    if (!out[i]) kept.push_back(i);
  if (kept.empty()) RELIGHT_USER_ERROR() << "leave-one-photo-out: no photo is left to solve the reflectance from";
  InverseProblem sub;
  sub.mesh = problem->mesh;
  sub.footprint_scale = problem->footprint_scale;
  sub.mesh_source = problem->mesh_source;
  sub.scratch_dir = problem->scratch_dir;
  sub.visibility = std::move(problem->visibility);
  ReflectanceState result;
  try {
    sub.observations = RestrictObservations(problem->observations, kept);
    InverseOptions o = options;
    o.fixed_lighting = o.fixed_reflectance = o.start_from_truth = false;
    o.map_resolution = "off";
    result = SolveInverse(sub, o).reflectance;
  } catch (...) {
    problem->visibility = std::move(sub.visibility);
    throw;
  }
  problem->visibility = std::move(sub.visibility);
  return result;
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
