// The `inverse` stage: alternating optimisation of the bilinear model
// (Haber et al. 2009, §5, eq. 9): lighting steps (per photo, lighting.h) and
// reflectance steps (materials and weights, reflectance.h) until the training
// objective settles, with a held-out share of the observations judging
// convergence (the iterate with the lowest held-out error is kept) and an
// explicit gauge for the global and per-channel scale ambiguity.
#pragma once

#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "observe/observations.h"
#include "solver/inverse_options.h"
#include "solver/lighting.h"
#include "solver/model.h"
#include "visibility/visibility.h"

namespace relight {

// Everything the solver reads.
struct InverseProblem {
  TriangleMesh mesh;                 // with vertex normals
  TriangleMesh occluders;            // <mesh>/occluders.ply (may be empty): blocks the bounce's rays
  VisibilityData visibility;
  ObservationSet observations;
  std::vector<ObservedPhoto> photos;
  double footprint_scale = 1.0;      // observe.footprint_scale: the surface disc each observation averages
  std::string mesh_source;           // mesh.source of the mesh stage (mvs, file or the truth's; empty: unknown)
  // Folder for the transport rows' scratch file (TransportOptions::spill_dir; the stages use their
  // output folder); empty keeps the rows in memory.
  std::string scratch_dir;
};

// The problem the stages before `inverse` wrote: <mesh>/mesh.ply (and occluders.ply when present, for
// inverse.interreflection), <visibility>/visibility.bin, <observe>/observations.bin and photos.json. Throws
// UserError naming the file that is missing, damaged or of another mesh.
InverseProblem ReadInverseProblem(const std::string& mesh_dir, const std::string& visibility_dir,
                                  const std::string& observe_dir);

// Optional known quantities (synthetic scenes): per-photo octahedral RGB maps
// at the solver's resolution (photo units, i.e. including exposure and white
// balance) and the true reflectance. They are held fixed with the
// fixed_lighting / fixed_reflectance options; a known reflectance that is not
// fixed is the starting point instead of the k-means initialisation.
struct KnownQuantities {
  std::vector<std::vector<float>> lighting_oct_rgb;  // [photo][texel * 3 + c]
  ReflectanceState reflectance;
  bool has_lighting = false;
  bool has_reflectance = false;
};

// One outer iteration.
struct IterationRecord {
  int iteration = 0;
  double train_rmse = 0;          // confidence-weighted, over training observations (linear units)
  double holdout_rmse = 0;        // over held-out observations (0 when none)
  // Σ α r (y − ŷ)² over training observations, r the iteration's robust reflectance weights
  // (inverse.robust_reflectance; r = 1 without): decides convergence and extrapolation.
  double objective = 0;
  double lighting_seconds = 0;
  double reflectance_seconds = 0;
  std::vector<double> photo_rmse;  // lighting-subset RMSE per photo
  double extrapolation = 0;        // accepted extrapolation step (0: none)
  double solve_seconds = 0;        // wall clock from the start of SolveInverse to the end of this iteration
};

// A model tried by automatic model selection.
struct ModelCandidate {
  std::string stage;                 // materials, basis or env_resolution
  std::string description;
  int materials = 0;
  std::vector<std::string> basis;    // lobe specs
  int env_resolution = 0;
  double holdout_rmse = 0;
  double train_rmse = 0;
  double seconds = 0;        // its short alternation
  double solve_seconds = 0;  // wall clock from the start of SolveInverse to its end
  bool chosen = false;
};

// One starting point of the alternation (inverse.init_gloss).
struct StartRecord {
  double init_gloss = 0;
  double score = 0;             // held-out RMSE of its best iterate (training RMSE without a hold-out)
  int best_iteration = 0;
  int iterations = 0;                // iterations run (fewer than the others' when it lost a race)
  double seconds = 0;
  std::vector<double> train_rmse;    // per iteration run
  std::vector<double> holdout_rmse;  // per iteration run (0 without a hold-out)
  std::vector<double> solve_seconds; // per iteration run: IterationRecord::solve_seconds
  bool chosen = false;
};

struct InverseSummary {
  std::vector<IterationRecord> iterations;
  int best_iteration = 0;
  double transport_seconds = 0;
  bool transport_footprint = false;        // rows averaged over observation footprints (inverse.transport_footprint)
  size_t transport_coefficients = 0;
  double transport_mean_coefficients_per_row = 0;
  // inverse.interreflection: time of the bounce's ray cast, vertices it reaches per vertex (mean), and the
  // indirect light's share of the Lambertian responses of the training observations at the end.
  double interreflection_seconds = 0;
  double interreflection_mean_sources = 0;
  double interreflection_share = 0;
  size_t interreflection_occluder_vertices = 0;  // occluder vertices the mesh receives bounced light from
  Eigen::Vector3d interreflection_occluder_albedo = Eigen::Vector3d::Zero();  // ReflectanceState::occluder_albedo
  size_t train_observations = 0;
  size_t holdout_observations = 0;
  size_t lower_bounds = 0;  // observations that are lower bounds (clipped footprints), train and held out
  double lower_bounds_missed = 0;          // share of training bound channels the final model stays >1% below
  double lower_bounds_mean_shortfall = 0;  // over those, mean (y − ŷ) / y
  std::string stop_reason;
  std::vector<StartRecord> starts;         // every start of the final model (one unless inverse.init_gloss lists several)
  std::vector<MapResolution> map_resolution;  // per photo: what the photos determine of its map (LightingResolution)
  double map_resolution_seconds = 0;
  std::vector<ModelCandidate> candidates;  // model selection: every model tried
  std::string chosen_model;                // the model of the final solve
  double selection_seconds = 0;
  double seconds = 0;

  // One paragraph for the log.
  std::string BriefReport() const;
};

struct InverseResult {
  LightingState lighting;
  ReflectanceState reflectance;
  InverseSummary summary;
};

// Solves the problem (library entry point for the stage, tests and sweeps).
// Whether the transport rows average over footprints (inverse.transport_footprint; auto by problem.mesh_source).
bool UseFootprintRows(const InverseOptions& o, const InverseProblem& problem);
// mesh.source as the mesh stage recorded it in <mesh_dir>/mesh_summary.json ("" when absent).
std::string ReadMeshSource(const std::string& mesh_dir);

InverseResult SolveInverse(const InverseProblem& problem, const InverseOptions& options,
                           const KnownQuantities* known = nullptr);

// Runs the stage on a problem (ReadInverseProblem; its scratch folder becomes `output_dir`) with the known
// quantities of the fixed_* options and start_from_truth (empty without them; the stage's main reads them from
// the ground truth); writes envmaps/, reflectance.ply, materials.json, lighting.json and solve_summary.json into
// `output_dir`.
InverseSummary RunInverse(const InverseOptions& options, InverseProblem& problem, const KnownQuantities& known,
                          const std::string& output_dir);

}  // namespace relight
