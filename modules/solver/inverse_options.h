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
    "inverse", "Inverse rendering: one environment map per photo and per-vertex reflectance (bilinear solve)", 15};

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
           "Lighting representation: haar (all-frequency wavelets, the method) or sh (spherical harmonics baseline).")
        .Choices({"haar", "sh"});
    t->Add("env_resolution", &env_resolution, "Side of each recovered octahedral environment map (power of two).")
        .Range(4, 128);
    t->Add("sh_order", &sh_order, "Highest SH band when lighting_basis = sh ((order+1)² coefficients).").Range(1, 8);
    t->Add("transport", &transport,
           "How transport rows are built: pixel (exact: the local hemisphere splatted onto the global map, then "
           "Haar) or wavelet (the seed's: product projection of visibility and a tabulated BRDF slice, rotated by "
           "the blended wavelet rotation of the vertex normal). docs/BENCHMARKS.md compares them.")
        .Choices({"pixel", "wavelet"})
        .Advanced();
    t->Add("transport_keep_energy", &transport_keep_energy,
           "Each transport row keeps the fewest Haar coefficients holding this share of its energy.")
        .Range(0.5, 1.0)
        .Advanced();
    t->Add("transport_max_coefficients", &transport_max_coefficients, "At most this many coefficients per row.")
        .Range(1, 16384)
        .Advanced();
    t->Add("transport_footprint", &transport_footprint,
           "Pixel route: each row is the mean over the observation's footprint on the surface (the disc `observe` "
           "averages the photo over: observe.footprint_scale, widened by its pixels' width, kernel_scale), with the "
           "mesh's interpolated normals inside it, instead "
           "of the vertex normal alone, so narrow lobes predict the highlight the pixels saw. auto: on for a given "
           "mesh (mesh.source ground_truth or file), whose normals are the surface's; off for an MVS reconstruction, "
           "whose normals inside a footprint are estimates (measured in docs/RESULTS.md@15cf301).")
        .Choices({"auto", "on", "off"})
        .Advanced();
    t->Add("transport_supersampling", &transport_supersampling,
           "Pixel route (haar): each visibility texel's BRDF slice and splat onto the global map are evaluated at "
           "this many points per side. 0 (automatic): enough for one splat per global texel side, 1 at the default "
           "resolutions, 2 when env_resolution is twice visibility.resolution (a coarser quadrature aliases narrow "
           "lobes against the finer map; docs/RESULTS.md@15cf301 item 18).")
        .Range(0, 8)
        .Advanced();
    t->Add("basis", &basis,
           "Basis BRDFs: lambertian, ggx:ALPHA[:F0], cook_torrance:ALPHA[:F0], phong:EXPONENT. "
           "The first Lambertian lobe carries the albedo.");
    t->Add("materials", &materials,
           "Number of materials (k-means regions at initialisation). The default 6 is the paper's Minerva model; "
           "blends of more materials than the scene's true ones fit the synthetic scenes better "
           "(docs/RESULTS.md@15cf301). "
           "select_model chooses fewer when the held-out observations do not support them.")
        .Range(1, 32);
    t->Add("init", &init,
           "How materials start: colour (k-means on hue and saturation of the vertices' mean colours, each region's "
           "median colour as its diffuse colour; the paper) or vertex_fits (once the first lighting is known, k-means "
           "on per-vertex reflectance fits: diffuse colour direction and each glossy lobe's share, so materials of one "
           "hue that differ in gloss separate; docs/RESULTS.md@15cf301).")
        .Choices({"colour", "vertex_fits"})
        .Advanced();
    t->Add("init_gloss", &init_gloss,
           "Starting points of the alternation, one per value: every material starts with a neutral (white) specular "
           "of this share of its diffuse luminance, split evenly over the glossy lobes (0: none, the paper). Each "
           "start runs inverse.start_race_iterations iterations, and the one with the lowest held-out error goes on "
           "to the end; solve_summary.json lists every start. The bilinear problem has local minima: on the clean "
           "synthetic bunny the start 0.4 "
           "ends 0.65 dB of joint relighting above 0, on synthetic_tiny 0.7 dB below, and the held-out error ranks "
           "them as relighting does (docs/RESULTS.md@15cf301 items 19-20). Unused with a known reflectance.")
        .Range(0, 10)
        .Advanced();
    t->Add("start_race_iterations", &start_race_iterations,
           "With several starts (inverse.init_gloss): run every start this many iterations, then continue only the "
           "one with the lowest held-out error so far (0: every start runs the whole alternation). The default, the "
           "first full-resolution iteration after inverse.coarse_iterations, kept the start the full runs keep on "
           "the three synthetic scenes in about 0.6 of their alternation time (docs/RESULTS.md@15cf301 item 21); the "
           "leader can change later, so 0 is the safe choice when time does not matter.")
        .Range(0, 1000)
        .Advanced();
    t->Add("interreflection", &interreflection,
           "One bounce of diffuse light (solver/interreflection.h): a direction the scene blocks brings the light "
           "the surface there reflects diffusely, instead of none. mesh: between the mesh's own surfaces (the object "
           "onto itself, a reconstructed ground onto the object); mesh_and_occluders: <mesh>/occluders.ply also "
           "bounces, in one albedo recovered with the rest (a given ground the object stands on); off: direct light "
           "only, the paper's model. The occluders' albedo trades against the object's where few photos tell them "
           "apart, so mesh_and_occluders is for scenes whose ground visibly lights the object. Costs a ray cast of "
           "the mesh (144 rays a vertex), two gathers per iteration and, with occluders, rows for the occluder "
           "vertices the mesh sees; relight renders the same bounce.")
        .Choices({"off", "mesh", "mesh_and_occluders"});
    t->Add("sparsity", &sparsity,
           "Penalty on the sum of a vertex's material weights, relative to its data term (favours few materials).")
        .Range(0, 1)
        .Advanced();
    t->Add("weight_smoothness", &weight_smoothness,
           "Pull of each vertex's material weights towards its mesh neighbours', relative to its data term "
           "(0: independent vertices, as in the seed; docs/RESULTS.md@15cf301 item 17 measures 0 to 0.2).")
        .Range(0, 100)
        .Advanced();
    t->Add("smoothness", &smoothness,
           "Laplacian smoothness of environment maps, relative to the largest diagonal value of the system "
           "(seed: 0.01%).")
        .Range(0, 1)
        .Advanced();
    t->Add("light_prior", &light_prior,
           "Haar: what the smoothness prior pulls each environment map towards where the photos say little. "
           "natural: a daylight model (sky brighter overhead or at the horizon, a sun and its aureole, a uniform "
           "ground lit by them) fitted in every lighting step to the directions the photos do determine; "
           "smooth: a flat fill (the seed's Laplacian alone). Choose smooth for indoor or artificial light, "
           "where sky and ground do not apply. The SH baseline always uses its own band-limited smoothness.")
        .Choices({"natural", "smooth"});
    t->Add("wavelet_sparsity", &wavelet_sparsity,
           "Haar: a sparsity prior on every environment map's wavelet coefficients, the group L1 norm over each "
           "coefficient's RGB magnitude (the mean is free), weighted by this times the largest diagonal value of the "
           "system times the map's mean radiance, and reweighted from the current map in every IRLS pass. It keeps "
           "what the photos support (a sun, a skyline) and drops the colour noise the per-texel freedom otherwise "
           "fits; 0 leaves the Laplacian alone (the seed). 0.003 keeps the joint relighting of the synthetic scenes "
           "and lowers the map error of noisy photos by 7-15 %; 0.03 and more blur the lighting "
           "(docs/RESULTS.md@15cf301 item 20).")
        .Range(0, 100)
        .Advanced();
    t->Add("wavelet_sparsity_floor", &wavelet_sparsity_floor,
           "Smallest coefficient magnitude the sparsity reweighting divides by, relative to the map's mean radiance.")
        .Range(1e-6, 10)
        .Advanced();
    t->Add("irls_iterations", &irls_iterations,
           "Iteratively reweighted least-squares passes per lighting step (weights restart every step).")
        .Range(1, 20)
        .Advanced();
    t->Add("robust_loss", &robust_loss,
           "Robust reweighting of the lighting fit (and of the reflectance fit with robust_reflectance).")
        .Choices({"none", "huber", "cauchy"})
        .Advanced();
    t->Add("robust_scale", &robust_scale, "Robust threshold in units of the residuals' robust standard deviation.")
        .Range(0.1, 100)
        .Advanced();
    t->Add("robust_reflectance", &robust_reflectance,
           "Reweight the reflectance step (materials and weights) too: every reflectance step starts from robust "
           "weights of the current model's residuals (robust_loss, robust_scale, sigma per photo), so transient "
           "occluders seen in few photos do not leak into the materials. The objective that decides convergence is "
           "then the robustly weighted one. Off by default: without outliers it slows the joint fit "
           "(docs/RESULTS.md@15cf301).")
        .Advanced();
    t->Add("qp_solver", &qp_solver,
           "Non-negative lighting QP: projected_newton (active-set Newton on the dense system) or ceres "
           "(bounded Levenberg-Marquardt; slower, kept for comparison).")
        .Choices({"projected_newton", "ceres"})
        .Advanced();
    t->Add("lighting_max_observations", &lighting_max_observations,
           "Observations per photo used by lighting steps (a fixed random subset when there are more).")
        .Min(16)
        .Advanced();
    t->Add("coarse_iterations", &coarse_iterations,
           "The first iterations solve the lighting at half resolution (Haar coarse levels only; 8x cheaper), "
           "then at full resolution.")
        .Range(0, 100)
        .Advanced();
    t->Add("map_resolution", &map_resolution,
           "After the solve, measure what the photos determine of every map: the trace of the lighting step's "
           "resolution matrix (how many of the map's wavelet coefficients the photos fix; the rest comes from the "
           "priors), per wavelet level, and the finest detail resolved (lighting.json). One dense solve per photo "
           "and channel: about 0.3 s per photo at 32² maps on 2 cores, 64 times that at 64². auto: on up to 32² "
           "maps and for SH, off above.")
        .Choices({"auto", "on", "off"})
        .Advanced();
    t->Add("max_iterations", &max_iterations,
           "Outer lighting/reflectance iterations (at most; tolerance and time_budget_s stop earlier). On the "
           "synthetic bunnies the held-out error still falls after 6 (docs/RESULTS.md@15cf301).")
        .Range(1, 100);
    t->Add("tolerance", &tolerance, "Stop when the training objective changes by less than this (relative).")
        .Range(0, 1)
        .Advanced();
    t->Add("time_budget_s", &time_budget_s, "Stop the alternation after this many seconds (0: no limit).").Min(0);
    t->Add("material_iterations", &material_iterations, "Materials/weights alternations per reflectance step.")
        .Range(1, 20)
        .Advanced();
    t->Add("accelerate", &accelerate,
           "After every iteration, try an extrapolated step along the last update (line-search ALS) and keep it when "
           "it lowers the objective.")
        .Advanced();
    t->Add("holdout_fraction", &holdout_fraction,
           "Share of observations held out of the fit; their error judges convergence and picks the best iterate.")
        .Range(0, 0.5)
        .Advanced();
    t->Add("gauge", &gauge,
           "How the global and per-channel scale ambiguity is fixed: neutral_light (mean environment radiance is "
           "grey, 1 per channel) or neutral_albedo (mean diffuse albedo is grey, 0.5 per channel).")
        .Choices({"neutral_light", "neutral_albedo"})
        .Advanced();
    t->Add("seed", &seed, "Seed of random subsets and k-means.").Advanced();
    t->Add("select_model", &select_model,
           "Choose the number of materials (up to inverse.materials), the basis lobes (a subset of inverse.basis) and "
           "the map resolution (up to inverse.env_resolution) by held-out error; every candidate is reported in "
           "solve_summary.json. Costs about selection_iterations iterations per candidate. With fixed_lighting "
           "only the materials and lobes are chosen.");
    t->Add("selection_iterations", &selection_iterations, "Alternation iterations per candidate model.")
        .Range(2, 50)
        .Advanced();
    t->Add("selection_tolerance", &selection_tolerance,
           "Model selection keeps the simplest model whose held-out error is within this fraction of the best.")
        .Range(0, 1)
        .Advanced();
    t->Add("fixed_lighting", &fixed_lighting,
           "Use the ground-truth environment maps and solve only the reflectance (synthetic scenes).")
        .Advanced();
    t->Add("fixed_reflectance", &fixed_reflectance,
           "Use the ground-truth reflectance and solve only the lighting (synthetic scenes with ground-truth mesh). "
           "With fixed_lighting too, nothing is solved: the stage writes the truth at the solver's resolution, "
           "and the scores downstream are the ceiling the model and the evaluation allow.")
        .Advanced();
    t->Add("start_from_truth", &start_from_truth,
           "Start the reflectance (the true basis, materials and weights) from the ground truth instead of the "
           "k-means initialisation, then solve as usual (synthetic scenes with ground-truth mesh). Measures how much "
           "of the error is the optimisation's starting point rather than the data.")
        .Advanced();
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
