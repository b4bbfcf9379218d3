// Options of the `inverse` stage: per-photo environment maps and per-vertex
// reflectance from the bilinear system (Haber et al. 2009, §5).
#pragma once

#include <string>
#include <vector>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kInverseStage{
    "inverse", "Inverse rendering: one environment map per photo and per-vertex reflectance (bilinear solve)", 18};

struct InverseOptions {
  // Lighting representation.
  std::string lighting_basis = "haar";  // haar (the method) or sh (low-frequency baseline)
  int env_resolution = 32;              // side of each octahedral environment map (Haar)
  int sh_order = 2;                     // bands of the SH baseline
  std::string transport = "pixel";      // how transport rows are built: pixel or wavelet
  double transport_keep_energy = 0.999; // Haar truncation of each transport row
  int transport_max_coefficients = 256; // cap per row
  std::string transport_footprint = "auto";  // rows average over each observation's footprint: auto, on or off
  int transport_supersampling = 0;      // sub-samples per visibility texel side (0: automatic)
  std::string interreflection = "mesh";  // one bounce of light: off, mesh (between its surfaces) or mesh_and_occluders

  // Reflectance model.
  std::vector<std::string> basis = {"lambertian", "ggx:0.1", "ggx:0.3", "phong:50", "phong:500"};
  int materials = 6;                    // materials (k-means regions at initialisation)
  std::string init = "colour";          // colour (k-means on mean colours, the paper) or vertex_fits
  std::vector<double> init_gloss = {0, 0.4};  // starts: neutral specular share of each material (0: the paper's)
  int start_race_iterations = 4;        // every start runs this many iterations, the best goes on (0: all run fully)
  double sparsity = 1e-3;               // penalty on the sum of per-vertex weights (favours few materials)
  double weight_smoothness = 0.01;      // pull of a vertex's weights towards its neighbours'

  // Lighting step.
  double smoothness = 1e-4;             // Laplacian weight relative to the system's largest diagonal value
  std::string light_prior = "natural";  // what fills unseen directions (haar): natural (a daylight model) or smooth
  double wavelet_sparsity = 0.003;      // group-L1 weight of the maps' Haar coefficients (relative; 0: off)
  double wavelet_sparsity_floor = 0.01; // IRLS floor of a coefficient's magnitude, relative to the map's mean
  int irls_iterations = 2;              // reweighting passes per lighting step (restarted every step)
  std::string robust_loss = "huber";    // none, huber or cauchy
  double robust_scale = 2.0;            // robust threshold in units of the residuals' robust sigma
  bool robust_reflectance = false;      // reweight the reflectance step's observations robustly too
  std::string qp_solver = "projected_newton";  // projected_newton or ceres
  int lighting_max_observations = 4096;        // per photo; a fixed random subset when there are more
  int coarse_iterations = 3;            // first iterations solve lighting at half resolution (haar)
  std::string map_resolution = "auto";  // what the photos determine of each map: auto (up to 32² maps), on, off

  // Alternation.
  int max_iterations = 12;              // outer lighting/reflectance iterations
  double tolerance = 2e-3;              // stop when the training objective changes less than this (relative)
  double time_budget_s = 0;             // stop after this much time (0: no limit)
  int material_iterations = 2;          // materials/weights alternations per reflectance step
  bool accelerate = true;               // try an extrapolated step after every iteration
  double holdout_fraction = 0.1;        // observations held out to judge convergence (0: none)
  std::string gauge = "neutral_light";  // neutral_light or neutral_albedo
  int seed = 1;                         // random subsets and k-means

  // Model selection.
  bool select_model = false;            // choose materials, lobes and map resolution by held-out error
  int selection_iterations = 4;         // alternation iterations per candidate model
  double selection_tolerance = 0.02;    // the simplest model within this of the best held-out error wins

  // Known quantities, for experiments and tests on synthetic scenes.
  bool fixed_lighting = false;          // use the ground-truth environment maps; solve reflectance only
  bool fixed_reflectance = false;       // use the ground-truth reflectance; solve lighting only
  bool start_from_truth = false;        // start the reflectance from the ground truth instead of k-means

  void Declare(OptionTable* t) {
    t->Add("lighting_basis", &lighting_basis,
           "Lighting representation: haar (all-frequency wavelets: suns, skylines, lamps) or sh "
           "(spherical harmonics, a low-frequency baseline to compare with).")
        .Choices({"haar", "sh"});
    t->Add("env_resolution", &env_resolution,
           "Side of each recovered octahedral environment map (power of two). 64 for known lighting or a "
           "specular object with detailed reflections; 16 for a quick look at a small collection "
           "(docs/TUNING.md).")
        .Range(4, 128);
    t->Add("sh_order", &sh_order, "Highest spherical-harmonics band ((order+1)² coefficients per map).")
        .Range(1, 8)
        .OnlyWhen("lighting_basis", {"sh"});
    t->Add("transport", &transport,
           "How transport rows are built: pixel (the local hemisphere splatted onto the global map, then "
           "Haar) or wavelet (product projection of visibility and a tabulated BRDF slice, rotated by "
           "the blended wavelet rotation of the vertex normal; the route the method started from, kept "
           "to compare against).")
        .Choices({"pixel", "wavelet"})
        .Experimental();
    t->Add("transport_keep_energy", &transport_keep_energy,
           "Each transport row keeps the fewest Haar coefficients holding this share of its energy; "
           "lower is faster and coarser.")
        .Range(0.5, 1.0)
        .Advanced();
    t->Add("transport_max_coefficients", &transport_max_coefficients,
           "At most this many Haar coefficients per transport row.")
        .Range(1, 16384)
        .Advanced();
    t->Add("transport_footprint", &transport_footprint,
           "Each row averages over the observation's footprint on the surface (the disc observe averaged "
           "the photo over) with the mesh's interpolated normals, instead of using the vertex normal "
           "alone, so narrow lobes predict the highlight the pixels saw. auto: on for a given mesh "
           "(mesh.source ground_truth or file), whose normals are the surface's; off for an MVS "
           "reconstruction, whose normals inside a footprint are estimates.")
        .Choices({"auto", "on", "off"})
        .Advanced()
        .OnlyWhen("transport", {"pixel"});
    t->Add("transport_supersampling", &transport_supersampling,
           "Each visibility texel's BRDF slice and splat onto the global map are evaluated at this many "
           "points per side. 0: automatic, enough for one splat per global texel side (1 at the default "
           "resolutions, 2 when env_resolution is twice visibility.resolution); raise it only to check "
           "that narrow lobes do not alias.")
        .Range(0, 8)
        .Advanced()
        .OnlyWhen("transport", {"pixel"});
    t->Add("basis", &basis,
           "Basis BRDFs every material blends: lambertian, ggx:ALPHA[:F0], cook_torrance:ALPHA[:F0], "
           "phong:EXPONENT; the first Lambertian lobe carries the albedo. Fewer lobes solve faster; give "
           "the family when it is known (docs/TUNING.md).");
    t->Add("materials", &materials,
           "Number of materials (k-means regions at initialisation). Raise it for objects with many "
           "distinct materials; select_model chooses fewer when the held-out observations do not support "
           "them.")
        .Range(1, 32);
    t->Add("init", &init,
           "How materials start: colour (k-means on hue and saturation of the vertices' mean colours, "
           "each region's median colour as its diffuse colour; the paper) or vertex_fits (once the first "
           "lighting is known, k-means on per-vertex reflectance fits, so materials of one hue that "
           "differ in gloss separate).")
        .Choices({"colour", "vertex_fits"})
        .Advanced();
    t->Add("init_gloss", &init_gloss,
           "Starting points of the alternation, one per value: every material starts with a neutral "
           "(white) specular of this share of its diffuse luminance, split evenly over the glossy lobes "
           "(0: none, the paper). The starts race (start_race_iterations) and the one with the lowest "
           "held-out error goes on; solve_summary.json lists every start. The bilinear problem has local "
           "minima, so several starts are safer; [0] alone saves time (docs/TUNING.md).")
        .Range(0, 10)
        .Advanced();
    t->Add("start_race_iterations", &start_race_iterations,
           "With several starts (init_gloss): run every start this many iterations, then continue only "
           "the one with the lowest held-out error so far. The leader can change later, so 0 (every "
           "start runs the whole alternation) is the safe choice when time does not matter.")
        .Range(0, 1000)
        .Advanced();
    t->Add("interreflection", &interreflection,
           "One bounce of diffuse light between surfaces (solver/interreflection.h). mesh: within the "
           "mesh; mesh_and_occluders: <mesh>/occluders.ply (a given ground that visibly lights the "
           "object) bounces too, its albedo recovered; off: direct light only, the paper's model.")
        .Choices({"off", "mesh", "mesh_and_occluders"});
    t->Add("sparsity", &sparsity,
           "Penalty on the sum of a vertex's material weights, relative to its data term (favours few "
           "materials per vertex).")
        .Range(0, 1)
        .Advanced();
    t->Add("weight_smoothness", &weight_smoothness,
           "Pull of each vertex's material weights towards its mesh neighbours', relative to its data "
           "term; 0: independent vertices. Lower keeps material borders sharp on clean data; higher lets "
           "noisy or weakly seen vertices follow their neighbours (docs/TUNING.md).")
        .Range(0, 100)
        .Advanced();
    t->Add("smoothness", &smoothness,
           "Laplacian smoothness of the environment maps, relative to the largest diagonal value of the "
           "system.")
        .Range(0, 1)
        .Advanced();
    t->Add("light_prior", &light_prior,
           "What fills the directions the photos say little about: natural (a daylight model fitted "
           "to what the photos determine: sky, sun, a ground lit by them, weighted per map by how much "
           "of the seen part's variation it explains, blending into the smooth fill for maps it does "
           "not describe; under a clear sky the sun is solved as a light of its own, sharper than a "
           "texel) or smooth (a flat fill from the seen directions, for every map). Choose smooth for "
           "indoor, studio or lab light.")
        .Choices({"natural", "smooth"})
        .OnlyWhen("lighting_basis", {"haar"});
    t->Add("wavelet_sparsity", &wavelet_sparsity,
           "Weight of a sparsity prior on every map's Haar coefficients (group L1 over each "
           "coefficient's RGB magnitude, relative to the system's largest diagonal value and the map's "
           "mean radiance; reweighted in every IRLS pass). It keeps what the photos support (a sun, a "
           "skyline) and drops colour noise; higher blurs the lighting, 0 leaves the Laplacian alone.")
        .Range(0, 100)
        .Advanced()
        .OnlyWhen("lighting_basis", {"haar"});
    t->Add("wavelet_sparsity_floor", &wavelet_sparsity_floor,
           "Smallest coefficient magnitude the sparsity reweighting divides by, relative to the map's "
           "mean radiance.")
        .Range(1e-6, 10)
        .Advanced()
        .OnlyWhen("lighting_basis", {"haar"});
    t->Add("irls_iterations", &irls_iterations,
           "Iteratively reweighted least-squares passes per lighting step (weights restart every step).")
        .Range(1, 20)
        .Advanced();
    t->Add("robust_loss", &robust_loss,
           "Robust reweighting of the lighting fit (and of the reflectance fit with robust_reflectance). "
           "none suits calibrated lab photos without outliers.")
        .Choices({"none", "huber", "cauchy"})
        .Advanced();
    t->Add("robust_scale", &robust_scale, "Robust threshold in units of the residuals' robust standard deviation.")
        .Range(0.1, 100)
        .Advanced()
        .OnlyWhen("robust_loss", {"huber", "cauchy"});
    t->Add("robust_reflectance", &robust_reflectance,
           "Reweight the reflectance step (materials and weights) robustly too, from the current model's "
           "residuals, so transient occluders seen in few photos stay out of the materials; convergence "
           "is then judged on the robustly weighted objective. Set it for collections with many "
           "transients (people, cars); without outliers it slows the joint fit.")
        .Advanced()
        .OnlyWhen("robust_loss", {"huber", "cauchy"});
    t->Add("qp_solver", &qp_solver,
           "Non-negative lighting QP: projected_newton (active-set Newton on the dense system) or ceres "
           "(bounded Levenberg-Marquardt; slower, kept to compare against).")
        .Choices({"projected_newton", "ceres"})
        .Experimental();
    t->Add("lighting_max_observations", &lighting_max_observations,
           "Observations per photo used by lighting steps (a fixed random subset when there are more); "
           "more is slower and steadier.")
        .Min(16)
        .Advanced();
    t->Add("coarse_iterations", &coarse_iterations,
           "The first iterations solve the lighting at half resolution (Haar coarse levels only; 8x "
           "cheaper), then at full resolution.")
        .Range(0, 100)
        .Advanced()
        .OnlyWhen("lighting_basis", {"haar"});
    t->Add("map_resolution", &map_resolution,
           "After the solve, measure what the photos determine of every map (lighting.json): the trace "
           "of the lighting step's resolution matrix per wavelet level and the finest detail resolved. "
           "One dense solve per photo and channel, cheap at 32² maps and 64 times dearer at 64². auto: "
           "on up to 32² maps and for SH, off above.")
        .Choices({"auto", "on", "off"})
        .Advanced();
    t->Add("max_iterations", &max_iterations,
           "Outer lighting/reflectance iterations (at most; tolerance and time_budget_s stop earlier). "
           "Lower it when time is short; a very small, noisy collection fits its noise after a few "
           "(docs/TUNING.md).")
        .Range(1, 100);
    t->Add("tolerance", &tolerance, "Stop when the training objective changes by less than this (relative).")
        .Range(0, 1)
        .Advanced();
    t->Add("time_budget_s", &time_budget_s,
           "Stop the alternation after this many seconds and keep the best iterate so far (0: no limit).")
        .Min(0);
    t->Add("material_iterations", &material_iterations, "Materials/weights alternations per reflectance step.")
        .Range(1, 20)
        .Advanced();
    t->Add("accelerate", &accelerate,
           "After every iteration, try an extrapolated step along the last update (line-search ALS) and "
           "keep it when it lowers the objective.")
        .Advanced();
    t->Add("holdout_fraction", &holdout_fraction,
           "Share of observations held out of the fit; their error judges convergence, picks the best "
           "iterate and ranks starts and models.")
        .Range(0, 0.5)
        .Advanced();
    t->Add("gauge", &gauge,
           "How the global and per-channel scale ambiguity is fixed: neutral_light (mean environment "
           "radiance is grey, 1 per channel) or neutral_albedo (mean diffuse albedo is grey, 0.5 per "
           "channel).")
        .Choices({"neutral_light", "neutral_albedo"})
        .Advanced();
    t->Add("seed", &seed, "Seed of random subsets and k-means.").Advanced();
    t->Add("select_model", &select_model,
           "Choose the number of materials (up to materials), the lobes (a subset of basis) and the map "
           "resolution (up to env_resolution) by held-out error, at about selection_iterations "
           "iterations per candidate; solve_summary.json lists them.");
    t->Add("selection_iterations", &selection_iterations, "Alternation iterations per candidate model.")
        .Range(2, 50)
        .Advanced()
        .OnlyWhen("select_model", {"true"});
    t->Add("selection_tolerance", &selection_tolerance,
           "Model selection keeps the simplest model whose held-out error is within this fraction of the "
           "best.")
        .Range(0, 1)
        .Advanced()
        .OnlyWhen("select_model", {"true"});
    t->Add("fixed_lighting", &fixed_lighting,
           "Use the ground-truth environment maps and solve only the reflectance (synthetic scenes).")
        .Experimental();
    t->Add("fixed_reflectance", &fixed_reflectance,
           "Use the ground-truth reflectance and solve only the lighting (synthetic scenes with the "
           "ground-truth mesh). With fixed_lighting too, nothing is solved: the truth is written at the "
           "solver's resolution, the ceiling of the scores downstream.")
        .Experimental();
    t->Add("start_from_truth", &start_from_truth,
           "Start the reflectance (basis, materials and weights) from the ground truth instead of "
           "k-means, then solve as usual (synthetic scenes with the ground-truth mesh): how much of the "
           "error is the starting point.")
        .Experimental();
  }
  void Check() const {
    if (env_resolution & (env_resolution - 1)) {
      RELIGHT_USER_ERROR() << "inverse.env_resolution = " << env_resolution << " must be a power of two";
    }
    if (basis.empty()) RELIGHT_USER_ERROR() << "inverse.basis must list at least one BRDF";
    if (init_gloss.empty()) RELIGHT_USER_ERROR() << "inverse.init_gloss must list at least one start (0: the paper's)";
    if (transport == "wavelet" && lighting_basis != "haar") {
      RELIGHT_USER_ERROR() << "inverse.transport = wavelet needs inverse.lighting_basis = haar";
    }
  }
};

}  // namespace relight
