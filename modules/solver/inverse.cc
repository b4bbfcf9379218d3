#include "solver/inverse.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <random>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "image/color.h"
#include "image/image.h"
#include "solver/interreflection.h"
#include "solver/lighting.h"
#include "solver/lobe_spec.h"
#include "solver/natural_light.h"
#include "solver/reflectance.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "visibility/bounce.h"
#include "wavelet/haar.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

// Mean radiance per channel over the sphere and all photos (solid-angle weighted).
Eigen::Vector3d MeanRadiance(const LightingState& l) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  if (l.values.empty()) return sum;
  if (l.basis == "haar") {
    const std::vector<double> omega = OctTexelSolidAngles(l.env_resolution);
    for (const auto& photo : l.values)
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < l.dim; ++k) sum[c] += photo[c][k] * omega[k];
    return sum / (4 * M_PI * l.values.size());
  }
  for (const auto& photo : l.values)
    for (int c = 0; c < 3; ++c) sum[c] += photo[c][0] / std::sqrt(4 * M_PI);
  return sum / double(l.values.size());
}

Eigen::Vector3d MeanAlbedo(const ReflectanceState& r, const std::vector<char>& observed) {
  int lambert = -1;
  for (int b = 0; b < r.num_lobes(); ++b)
    if (r.basis[b].model == BrdfModel::kLambertian) lambert = b;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double n = 0;
  if (lambert < 0) return Eigen::Vector3d::Ones();
  const size_t nv = r.weights.size() / r.num_materials;
  for (size_t v = 0; v < nv; ++v) {
    if (!observed[v]) continue;
    for (int m = 0; m < r.num_materials; ++m)
      sum += r.weights[v * r.num_materials + m] * r.coefficients[m * r.num_lobes() + lambert];
    n += 1;
  }
  return n > 0 ? Eigen::Vector3d(sum / n) : Eigen::Vector3d::Ones();
}

// Scales lighting channel c by s_c and materials by 1/s_c (the product is unchanged).
void ApplyGauge(const Eigen::Vector3d& s, LightingState* l, ReflectanceState* r) {
  l->ScaleChannels(s);
  for (auto& coeff : r->coefficients) coeff = coeff.cwiseQuotient(s);
  r->occluder_albedo = r->occluder_albedo.cwiseQuotient(s);
}

Eigen::Vector3d GaugeScale(const std::string& gauge, const LightingState& l, const ReflectanceState& r,
                           const std::vector<char>& observed) {
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  if (gauge == "neutral_light") {
    const Eigen::Vector3d mean = MeanRadiance(l);
    for (int c = 0; c < 3; ++c) s[c] = mean[c] > 1e-30 ? 1.0 / mean[c] : 1.0;
  } else {
    const Eigen::Vector3d albedo = MeanAlbedo(r, observed);
    for (int c = 0; c < 3; ++c) s[c] = albedo[c] > 1e-30 ? albedo[c] / 0.5 : 1.0;
  }
  return s;
}

// θ = prev + step (cur − prev), clamped to the feasible set (non-negative).
void Extrapolate(const LightingState& prev_l, const ReflectanceState& prev_r, double step, LightingState* l,
                 ReflectanceState* r) {
  l->ExtrapolateFrom(prev_l, step);
  for (size_t k = 0; k < r->coefficients.size(); ++k)
    r->coefficients[k] = (prev_r.coefficients[k] + step * (r->coefficients[k] - prev_r.coefficients[k])).cwiseMax(0.0);
  for (size_t k = 0; k < r->weights.size(); ++k)
    r->weights[k] = std::max(0.0f, static_cast<float>(prev_r.weights[k] + step * (r->weights[k] - prev_r.weights[k])));
  r->occluder_albedo = (prev_r.occluder_albedo + step * (r->occluder_albedo - prev_r.occluder_albedo)).cwiseMax(0.0);
}

}  // namespace

namespace {

// What every candidate model of one solve shares.
struct SolveContext {
  const InverseProblem& problem;
  const InverseOptions& o;
  const KnownQuantities* known;
  const TransportStore& transport;
  std::vector<uint32_t> train, holdout;
  std::vector<uint32_t> train_exact;          // train without lower bounds (initialisation)
  std::vector<std::vector<uint32_t>> subset;  // per photo, lighting-step observations
  std::vector<std::vector<uint32_t>> neighbours;
  std::vector<char> observed;
  const Timer* solve_timer = nullptr;  // started with SolveInverse: IterationRecord::solve_seconds
  // inverse.interreflection: the bounce between the mesh's vertices (lagged, solver/interreflection.h); null: off.
  IndirectLight* indirect = nullptr;

  // Makes the indirect light that of (lighting, reflectance); unobserved vertices reflect with their
  // neighbours' weights, as the result will.
  void UpdateIndirect(const LightingState& lighting, const ReflectanceState& reflectance) const {
    if (indirect == nullptr) return;
    ReflectanceState filled = reflectance;
    FillUnobservedWeights(problem.mesh, observed, &filled);
    indirect->Update(lighting, filled);
  }
  // Per-lobe responses of `ids` under `lighting`, the bounce (at its last update) included.
  std::vector<float> Responses(const std::vector<uint32_t>& ids, const LightingState& lighting) const {
    std::vector<float> responses = ComputeLobeResponses(transport, problem.observations, ids, lighting);
    if (indirect != nullptr) indirect->AddToResponses(ids, 1.0f, &responses);
    return responses;
  }
};

// One candidate model.
struct ModelSpec {
  std::vector<char> lobe_enabled;  // per basis lobe
  int materials = 1;
  int solve_resolution = 0;  // haar: lighting solved at this resolution (0: full)
  int max_iterations = 6;
  int coarse_iterations = 3;
  double init_gloss = 0;  // neutral specular share of the colour start (inverse.init_gloss)
};

struct AlternationResult {
  LightingState lighting;
  ReflectanceState reflectance;
  std::vector<IterationRecord> iterations;
  int best_iteration = 0;
  double best_score = 1e300;  // held-out RMSE (training RMSE without a hold-out)
  std::string stop_reason;
};

std::string DescribeSpec(const ModelSpec& spec, const std::vector<BrdfLobe>& basis, int env_resolution) {
  std::string lobes;
  for (size_t b = 0; b < basis.size(); ++b) {
    if (!spec.lobe_enabled[b]) continue;
    lobes += (lobes.empty() ? "" : "+") + LobeSpec(basis[b]);
  }
  const int res = spec.solve_resolution > 0 ? spec.solve_resolution : env_resolution;
  return std::to_string(spec.materials) + " materials, " + lobes + ", env " + std::to_string(res) + "²";
}

// An alternation that can be paused between iterations and resumed
// (inverse.start_race_iterations runs every start a few iterations, then
// continues the best one). Everything one iteration needs from the previous
// ones lives here.
struct Alternation {
  AlternationResult result;
  LightingState best_lighting;
  ReflectanceState best_reflectance;
  std::vector<BrdfLobe> basis;
  double previous_objective = -1;
  double seconds = 0;  // time spent in iterations so far
  int next_iteration = 0;
  bool refit_initialisation = false;
  bool finished = false;       // converged, fixed, or out of budget: no more iterations
  bool solve_lighting = true;  // false: the lighting is known and fixed
  bool solve_reflectance = true;
};

// With the occluders' bounce: their albedo from the light they bounce onto the mesh under the current
// model (`responses` of `ids`, the bounce included, are updated to the new albedo).
void FitOccluderAlbedo(const SolveContext& ctx, const std::vector<uint32_t>& ids, ReflectanceState* reflectance,
                       std::vector<float>* responses) {
  if (ctx.indirect == nullptr || !ctx.indirect->has_occluders()) return;
  const Eigen::Vector3d albedo = ctx.indirect->FitOccluderAlbedo(ids, *responses, *reflectance);
  ctx.indirect->AddToResponses(ids, -1.0f, responses);
  ctx.indirect->SetOccluderAlbedo(albedo);
  reflectance->occluder_albedo = albedo;
  ctx.indirect->AddToResponses(ids, 1.0f, responses);
}

// Sets up an alternation at its starting point (no iteration run yet).
Alternation StartAlternation(const SolveContext& ctx, const ModelSpec& spec) {
  const InverseOptions& o = ctx.o;
  const ObservationSet& obs = ctx.problem.observations;
  const size_t nv = ctx.problem.mesh.num_vertices();
  const int num_photos = static_cast<int>(obs.num_photos);
  const KnownQuantities* known = ctx.known;
  Alternation a;
  a.basis = known != nullptr && known->has_reflectance ? known->reflectance.basis : ParseLobeSpecs(o.basis);
  LightingState& lighting = a.result.lighting;
  lighting.basis = o.lighting_basis;
  lighting.env_resolution = o.env_resolution;
  lighting.sh_order = o.sh_order;
  lighting.Resize(num_photos);
  ReflectanceState& reflectance = a.result.reflectance;
  if (known != nullptr && known->has_reflectance) {
    reflectance = known->reflectance;  // fixed, or a warm start
  } else {
    reflectance = InitializeReflectance(obs, ctx.train_exact, nv, a.basis, spec.materials, o.seed, spec.init_gloss,
                                        &spec.lobe_enabled);
  }
  if (!(o.fixed_reflectance && known != nullptr && known->has_reflectance))
    reflectance.lobe_enabled = spec.lobe_enabled;
  a.solve_lighting = !(known != nullptr && known->has_lighting && o.fixed_lighting);
  a.solve_reflectance = !(o.fixed_reflectance && known != nullptr && known->has_reflectance);
  if (!a.solve_lighting) {
    RELIGHT_CHECK(o.lighting_basis == "haar") << "fixed lighting needs the haar basis";
    for (int i = 0; i < num_photos; ++i)
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < lighting.dim; ++k) lighting.values[i][c][k] = known->lighting_oct_rgb[i][k * 3 + c];
    lighting.UpdateCoefficients();
  }
  a.refit_initialisation =
      a.solve_reflectance && o.init == "vertex_fits" && !(known != nullptr && known->has_reflectance);
  if (ctx.indirect != nullptr && ctx.indirect->has_occluders() && reflectance.occluder_albedo.isZero())
    reflectance.occluder_albedo.setConstant(kOccluderAlbedoStart);
  a.result.stop_reason = "max_iterations reached";
  return a;
}

// Runs iterations of `a` until it finishes or `stop_before` iterations have run
// (resume by calling again). `progress_label`: when non-empty, a progress bar
// (with ETA) over the iterations and one info line per iteration; model-selection
// candidates run quietly.
void ContinueAlternation(const SolveContext& ctx, const ModelSpec& spec, Alternation* a, int stop_before,
                         const std::string& progress_label = "") {
  const InverseOptions& o = ctx.o;
  const ObservationSet& obs = ctx.problem.observations;
  const size_t nv = ctx.problem.mesh.num_vertices();
  const std::vector<BrdfLobe>& basis = a->basis;
  AlternationResult& result = a->result;
  LightingState& lighting = result.lighting;
  ReflectanceState& reflectance = result.reflectance;
  const bool solve_lighting = a->solve_lighting;
  const bool solve_reflectance = a->solve_reflectance;
  bool& refit_initialisation = a->refit_initialisation;
  // Robust reweighting of the reflectance step (nothing to reweight when the reflectance is fixed).
  const bool use_robust = solve_reflectance && o.robust_reflectance && o.robust_loss != "none";
  const TransportStore& transport = ctx.transport;
  const std::vector<uint32_t>& train = ctx.train;
  // Lower bounds (clipped highlights) enter the reflectance step through
  // active sets (MetLowerBounds), refreshed before every materials and weights solve.
  const bool has_bounds = ctx.train_exact.size() < train.size();

  LightingState& best_lighting = a->best_lighting;
  ReflectanceState& best_reflectance = a->best_reflectance;
  double& previous_objective = a->previous_objective;
  Timer total;
  Timer step;
  // Alternating least squares converges slowly along the bilinear valley; an
  // extrapolated step along the last update (Bro 1998, "line search" ALS) is
  // tried after every iteration and kept when it lowers the objective.
  std::unique_ptr<Progress> progress;
  const int last = std::min(spec.max_iterations, stop_before);
  if (!progress_label.empty() && !a->finished && a->next_iteration < last)
    progress = std::make_unique<Progress>(progress_label, last - a->next_iteration);
  for (int iter = a->next_iteration; iter < last && !a->finished; ++iter) {
    a->next_iteration = iter + 1;
    IterationRecord rec;
    rec.iteration = iter + 1;
    const LightingState prev_lighting = lighting;
    const ReflectanceState prev_reflectance = reflectance;
    if (solve_lighting) {
      int resolution = spec.solve_resolution;
      const bool coarse =
          solve_reflectance && o.lighting_basis == "haar" && iter < spec.coarse_iterations && o.env_resolution >= 16;
      if (coarse) resolution = std::min(resolution > 0 ? resolution : o.env_resolution, o.env_resolution / 2);
      // With the bounce, the maps explain the photos minus the indirect light under the current model.
      ObservationSet direct_targets;
      if (ctx.indirect != nullptr) {
        ctx.UpdateIndirect(lighting, reflectance);
        direct_targets = ctx.indirect->DirectTargets(reflectance);
      }
      const LightingStepResult lr = SolveLighting(transport, ctx.indirect != nullptr ? direct_targets : obs, ctx.subset,
                                                  reflectance, o, &lighting, resolution);
      rec.lighting_seconds = lr.seconds;
      rec.photo_rmse = lr.photo_rmse;
    }
    step.Restart();
    ctx.UpdateIndirect(lighting, reflectance);
    std::vector<float> responses = ctx.Responses(train, lighting);
    if (refit_initialisation) {
      // inverse.init = vertex_fits: the materials start from per-vertex fits under this first lighting.
      const std::vector<float> exact_responses =
          has_bounds ? ctx.Responses(ctx.train_exact, lighting) : std::vector<float>();
      reflectance = InitializeReflectanceFromFits(obs, ctx.train_exact, has_bounds ? exact_responses : responses, nv,
                                                  basis, spec.materials, o.seed);
      reflectance.lobe_enabled = spec.lobe_enabled;
      for (int m = 0; m < reflectance.num_materials; ++m)
        for (int b = 0; b < reflectance.num_lobes(); ++b)
          if (!reflectance.enabled(b)) reflectance.coefficients[m * reflectance.num_lobes() + b].setZero();
      refit_initialisation = false;
    }
    // Robust weights of the current model's residuals (this lighting, the previous reflectance),
    // held fixed through this iteration: the reflectance step, the extrapolation test and the
    // objective (the IRLS surrogate Σ α r (y − ŷ)²) all use them.
    std::vector<float> robust;
    if (use_robust)
      robust = ReflectanceRobustWeights(obs, train, responses, reflectance, o.robust_loss, o.robust_scale);
    const std::vector<float>* robust_ptr = use_robust ? &robust : nullptr;
    if (solve_reflectance) {
      std::vector<uint8_t> met;
      for (int inner = 0; inner < o.material_iterations; ++inner) {
        if (has_bounds) met = MetLowerBounds(obs, train, responses, reflectance);
        SolveMaterials(obs, train, responses, &reflectance, robust_ptr, &met);
        if (has_bounds) met = MetLowerBounds(obs, train, responses, reflectance);
        SolveWeights(obs, train, responses, o.sparsity, &reflectance, &ctx.neighbours, o.weight_smoothness, robust_ptr,
                     &met);
        FitOccluderAlbedo(ctx, train, &reflectance, &responses);
      }
    } else {
      FitOccluderAlbedo(ctx, train, &reflectance, &responses);
    }
    rec.reflectance_seconds = step.Seconds();
    double sse, weight;
    ResidualStats(obs, train, responses, reflectance, &sse, &weight, robust_ptr);
    if (o.accelerate && iter > 0 && solve_lighting && solve_reflectance) {
      // Try a few step lengths; the evaluation is cheap next to a lighting step.
      // The best candidate so far is kept whole (model and responses), so taking
      // it costs no further evaluation.
      double best_step = 0;
      LightingState best_l;
      ReflectanceState best_r;
      std::vector<float> best_resp;
      for (double trial : {1.5, 3.0, 6.0, 12.0}) {
        LightingState cand_l = lighting;
        ReflectanceState cand_r = reflectance;
        Extrapolate(prev_lighting, prev_reflectance, trial, &cand_l, &cand_r);
        // The bounce held at this iteration's, but for the occluders' albedo (it enters linearly).
        if (ctx.indirect != nullptr) ctx.indirect->SetOccluderAlbedo(cand_r.occluder_albedo);
        std::vector<float> cand_resp = ctx.Responses(train, cand_l);
        double cand_sse, cand_w;
        ResidualStats(obs, train, cand_resp, cand_r, &cand_sse, &cand_w, robust_ptr);
        if (cand_sse < sse) {
          sse = cand_sse;
          best_step = trial;
          best_l = std::move(cand_l);
          best_r = std::move(cand_r);
          best_resp = std::move(cand_resp);
        } else {
          break;  // longer steps only get worse along a convex valley
        }
      }
      if (best_step > 0) {
        lighting = std::move(best_l);
        reflectance = std::move(best_r);
        responses = std::move(best_resp);
        rec.extrapolation = best_step;
      }
      if (ctx.indirect != nullptr) ctx.indirect->SetOccluderAlbedo(reflectance.occluder_albedo);
    }
    // Gauge: fix the scale ambiguity (the product ρ·L is unchanged).
    if (solve_lighting && solve_reflectance) {
      const Eigen::Vector3d g = GaugeScale(o.gauge, lighting, reflectance, ctx.observed);
      ApplyGauge(g, &lighting, &reflectance);
      // Responses are linear in the lighting: channel c scales by g_c (equal to
      // recomputing them up to float rounding, at a fraction of the cost). The
      // bounce, ρ_h times the light, does not change with the gauge.
      if (ctx.indirect != nullptr) ctx.indirect->AddToResponses(train, -1.0f, &responses);
      ScaleResponses(g, &responses);
      if (ctx.indirect != nullptr) ctx.indirect->AddToResponses(train, 1.0f, &responses);
      ResidualStats(obs, train, responses, reflectance, &sse, &weight, robust_ptr);
    }
    rec.objective = sse;
    {
      // The reported RMSE stays the plain confidence-weighted one, comparable across iterations and runs.
      double plain_sse = sse, plain_weight = weight;
      if (use_robust) ResidualStats(obs, train, responses, reflectance, &plain_sse, &plain_weight);
      rec.train_rmse = std::sqrt(plain_sse / std::max(1e-30, plain_weight));
    }
    if (!ctx.holdout.empty()) {
      ctx.UpdateIndirect(lighting, reflectance);
      const std::vector<float> hr = ctx.Responses(ctx.holdout, lighting);
      double hs, hw;
      ResidualStats(obs, ctx.holdout, hr, reflectance, &hs, &hw);
      rec.holdout_rmse = std::sqrt(hs / std::max(1e-30, hw));
    }
    if (progress) {
      RLOG_INFO("iteration {}: train RMSE {:.5g}, held-out RMSE {:.5g} (lighting {:.1f} s, reflectance {:.1f} s)",
                rec.iteration, rec.train_rmse, rec.holdout_rmse, rec.lighting_seconds, rec.reflectance_seconds);
      progress->Advance();
    } else {
      RLOG_DEBUG("iteration {}: train RMSE {:.5g}, held-out RMSE {:.5g} (lighting {:.1f} s, reflectance {:.1f} s)",
                 rec.iteration, rec.train_rmse, rec.holdout_rmse, rec.lighting_seconds, rec.reflectance_seconds);
    }
    if (ctx.solve_timer != nullptr) rec.solve_seconds = ctx.solve_timer->Seconds();
    result.iterations.push_back(rec);
    const double score = ctx.holdout.empty() ? rec.train_rmse : rec.holdout_rmse;
    if (score < result.best_score) {
      result.best_score = score;
      best_lighting = lighting;
      best_reflectance = reflectance;
      result.best_iteration = rec.iteration;
    }
    if (previous_objective > 0 && std::abs(previous_objective - sse) <= o.tolerance * previous_objective) {
      result.stop_reason = "objective changed by less than inverse.tolerance";
      a->finished = true;
      break;
    }
    if (!solve_reflectance) {
      result.stop_reason = solve_lighting ? "the reflectance is fixed: a single lighting solve suffices"
                                          : "lighting and reflectance are fixed: the ground truth is scored";
      a->finished = true;
      break;
    }
    if (o.time_budget_s > 0 && a->seconds + total.Seconds() > o.time_budget_s) {
      result.stop_reason = "inverse.time_budget_s reached";
      a->finished = true;
      break;
    }
    previous_objective = sse;
  }
  a->seconds += total.Seconds();
  if (a->next_iteration >= spec.max_iterations) a->finished = true;
}

// The best iterate of a finished (or abandoned) alternation.
AlternationResult FinishAlternation(Alternation* a) {
  AlternationResult result = std::move(a->result);
  if (!result.iterations.empty()) {
    result.lighting = std::move(a->best_lighting);
    result.reflectance = std::move(a->best_reflectance);
  }
  return result;
}

AlternationResult Alternate(const SolveContext& ctx, const ModelSpec& spec, const std::string& progress_label = "") {
  Alternation a = StartAlternation(ctx, spec);
  ContinueAlternation(ctx, spec, &a, spec.max_iterations, progress_label);
  return FinishAlternation(&a);
}

// Model selection by held-out error (inverse.select_model): the candidates share the transport rows;
// each runs a short alternation; the simplest model within inverse.selection_tolerance of the best
// held-out error wins. Every candidate goes into summary->candidates; returns the chosen model.
ModelSpec SelectModel(const SolveContext& ctx, ModelSpec spec, const std::vector<BrdfLobe>& basis, const Timer& total,
                      InverseSummary* summary) {
  const InverseOptions& o = ctx.o;
  Timer selection;
  auto evaluate = [&](const ModelSpec& candidate, const std::string& stage) {
    ModelSpec s = candidate;
    s.max_iterations = o.selection_iterations;
    s.coarse_iterations = std::min(o.coarse_iterations, o.selection_iterations - 1);
    Timer candidate_timer;
    const AlternationResult r = Alternate(ctx, s);
    ModelCandidate c;
    c.seconds = candidate_timer.Seconds();
    c.solve_seconds = total.Seconds();
    c.stage = stage;
    c.description = DescribeSpec(candidate, basis, o.env_resolution);
    c.materials = candidate.materials;
    for (size_t b = 0; b < basis.size(); ++b)
      if (candidate.lobe_enabled[b]) c.basis.push_back(LobeSpec(basis[b]));
    c.env_resolution = candidate.solve_resolution > 0 ? candidate.solve_resolution : o.env_resolution;
    c.holdout_rmse = r.best_score;
    c.train_rmse = r.iterations[r.best_iteration - 1].train_rmse;
    summary->candidates.push_back(c);
    RLOG_INFO("model selection ({}): {}: held-out RMSE {:.5g}", stage, c.description, c.holdout_rmse);
    return r.best_score;
  };
  auto pick = [&](const std::vector<ModelSpec>& options_in_order, const std::string& stage) {
    // Candidates ordered from simplest to richest; keep the simplest within tolerance of the best.
    std::vector<double> score;
    for (const auto& c : options_in_order) score.push_back(evaluate(c, stage));
    const double best = *std::min_element(score.begin(), score.end());
    for (size_t k = 0; k < score.size(); ++k)
      if (score[k] <= (1.0 + o.selection_tolerance) * best) return k;
    return score.size() - 1;
  };
  // 1. Number of materials.
  std::vector<ModelSpec> by_materials;
  for (int m : {1, 2, 3, 4, 6, 8}) {
    if (m > o.materials) break;
    ModelSpec c = spec;
    c.materials = m;
    by_materials.push_back(c);
  }
  if (by_materials.empty() || by_materials.back().materials != o.materials) {
    by_materials.push_back(spec);
  }
  spec = by_materials[pick(by_materials, "materials")];
  // 2. Basis lobes: drop each specular lobe that the held-out error does not miss.
  double current = 1e300;
  for (const auto& c : summary->candidates)
    if (c.stage == "materials" && c.materials == spec.materials) current = c.holdout_rmse;
  for (size_t b = 0; b < basis.size(); ++b) {
    if (basis[b].model == BrdfModel::kLambertian || !spec.lobe_enabled[b]) continue;
    ModelSpec c = spec;
    c.lobe_enabled[b] = 0;
    const double score = evaluate(c, "basis");
    if (score <= (1.0 + o.selection_tolerance) * current) {
      spec = c;
      current = std::min(current, score);
    }
  }
  // 3. Environment-map resolution (Haar): coarser maps when the photos do not support detail.
  if (o.lighting_basis == "haar" && !o.fixed_lighting) {
    std::vector<ModelSpec> by_resolution;
    for (int res = std::max(8, o.env_resolution / 4); res < o.env_resolution; res *= 2) {
      ModelSpec c = spec;
      c.solve_resolution = res;
      by_resolution.push_back(c);
    }
    by_resolution.push_back(spec);
    spec = by_resolution[pick(by_resolution, "env_resolution")];
  }
  for (auto& c : summary->candidates) {
    c.chosen = c.description == DescribeSpec(spec, basis, o.env_resolution) && c.stage != "chosen";
  }
  summary->selection_seconds = selection.Seconds();
  summary->chosen_model = DescribeSpec(spec, basis, o.env_resolution);
  RLOG_INFO("model selection chose {} ({:.1f} s)", summary->chosen_model, summary->selection_seconds);
  return spec;
}

// How the final model meets the training lower bounds (clipped footprints): the share of bound
// channels it stays more than 1% below (active bounds end at equality, up to the solver's
// tolerance), and by how much on average, relative to the bound.
void MeasureLowerBounds(const SolveContext& ctx, const InverseResult& result, InverseSummary* summary) {
  const ObservationSet& obs = ctx.problem.observations;
  const std::vector<uint32_t>& train = ctx.train;
  const std::vector<float> responses = ctx.Responses(train, result.lighting);
  size_t bounds = 0, missed = 0;
  double shortfall = 0;
  std::vector<float> rho(result.reflectance.num_lobes() * 3);
  const int b_count = result.reflectance.num_lobes();
  for (size_t k = 0; k < train.size(); ++k) {
    const Observation& ob = obs.records[train[k]];
    if (!ob.lower_bound()) continue;
    result.reflectance.VertexLobeWeights(ob.vertex, rho.data());
    for (int c = 0; c < 3; ++c) {
      if (!ob.lower_bound(c)) continue;
      ++bounds;
      if (ob.rgb[c] <= 0) continue;
      double pred = 0;
      for (int b = 0; b < b_count; ++b) pred += rho[b * 3 + c] * responses[(k * b_count + b) * 3 + c];
      if (pred >= 0.99 * ob.rgb[c]) continue;
      ++missed;
      shortfall += (ob.rgb[c] - pred) / ob.rgb[c];
    }
  }
  summary->lower_bounds_missed = bounds > 0 ? double(missed) / bounds : 0.0;
  summary->lower_bounds_mean_shortfall = missed > 0 ? shortfall / missed : 0.0;
  RLOG_INFO(
      "lower bounds: the model stays more than 1% below {:.1f}% of them (bound channels), by {:.1f}% on "
      "average",
      100 * summary->lower_bounds_missed, 100 * summary->lower_bounds_mean_shortfall);
}

}  // namespace

bool UseFootprintRows(const InverseOptions& o, const InverseProblem& problem) {
  if (o.transport != "pixel" || o.transport_footprint == "off") return false;
  if (o.transport_footprint == "on") return true;
  // auto: a given mesh's normals (a file's, the truth's) are the surface's; a reconstruction's are estimates.
  return !problem.mesh_source.empty() && problem.mesh_source != "mvs";
}

// The rows' lighting basis, map size and truncation from the inverse options.
TransportOptions SolveTransportOptions(const InverseOptions& o) {
  TransportOptions to;
  to.lighting_basis = o.lighting_basis;
  to.env_resolution = o.env_resolution;
  to.sh_order = o.sh_order;
  to.keep_energy = o.transport_keep_energy;
  to.max_coefficients = o.transport_max_coefficients;
  return to;
}

// The solve's transport rows (TransportOptions from the inverse options), with their counts and time in `summary`.
TransportStore BuildSolveTransport(const InverseProblem& problem, const InverseOptions& o,
                                   const std::vector<BrdfLobe>& basis, InverseSummary* summary) {
  Timer step;
  TransportOptions to = SolveTransportOptions(o);
  to.basis = basis;
  summary->transport_footprint = UseFootprintRows(o, problem);
  to.footprint_scale = summary->transport_footprint ? problem.footprint_scale : 0.0;
  to.route = o.transport;
  to.supersampling = o.transport_supersampling;
  to.spill_dir = problem.scratch_dir;
  TransportStore transport = BuildTransport(problem.mesh, problem.visibility, problem.observations, to);
  summary->transport_seconds = step.Seconds();
  summary->transport_coefficients = transport.num_coefficients();
  const size_t rows =
      problem.mesh.num_vertices() + problem.observations.records.size() * std::max(0, transport.num_lobes() - 1);
  summary->transport_mean_coefficients_per_row = double(transport.num_coefficients()) / std::max<size_t>(1, rows);
  RLOG_INFO("transport: {} observations x {} lobes, {:.1f} coefficients per row, {:.0f} MiB {}, {:.1f} s; {}",
            problem.observations.records.size(), basis.size(), summary->transport_mean_coefficients_per_row,
            transport.bytes() / 1048576.0, transport.on_disk() ? "in a scratch file" : "in memory",
            summary->transport_seconds,
            summary->transport_footprint ? "rows averaged over the observations' footprints"
                                         : "rows at the vertex normals (inverse.transport_footprint)");
  return transport;
}

InverseResult SolveInverse(const InverseProblem& problem, const InverseOptions& o, const KnownQuantities* known) {
  Timer total;
  InverseResult result;
  InverseSummary& summary = result.summary;
  const ObservationSet& obs = problem.observations;
  const size_t nv = problem.mesh.num_vertices();
  const int num_photos = static_cast<int>(obs.num_photos);
  if (obs.records.empty()) {
    RELIGHT_USER_ERROR() << "no observations: no vertex of the mesh is seen in any photo; check the observe stage";
  }
  // With the reflectance known (fixed or as a warm start), rows use its basis.
  const std::vector<BrdfLobe> basis =
      known != nullptr && known->has_reflectance ? known->reflectance.basis : ParseLobeSpecs(o.basis);

  const TransportStore transport = BuildSolveTransport(problem, o, basis, &summary);

  // Held-out and training observations; per-photo lighting subsets.
  SolveContext ctx{problem, o, known, transport, {}, {}, {}, {}, {}, {}};
  ctx.solve_timer = &total;
  // inverse.interreflection: the mesh's bounce samples (occluders block them), then the lagged indirect light.
  BounceSamples bounce;
  OccluderBounce occluder_bounce;
  std::unique_ptr<IndirectLight> indirect;
  if (o.interreflection != "off") {
    Timer bounce_timer;
    std::vector<const TriangleMesh*> scene{&problem.mesh};
    if (!problem.occluders.empty()) scene.push_back(&problem.occluders);
    const RayCaster caster(scene);
    // Occluders block the bounce's rays either way; with mesh_and_occluders they bounce light too.
    const bool occluders_bounce = o.interreflection == "mesh_and_occluders" && !problem.occluders.empty();
    BounceSamples occluder_samples;
    bounce =
        ComputeBounceSamples(problem.mesh, caster, BounceOptions(), occluders_bounce ? &occluder_samples : nullptr);
    if (occluders_bounce) {
      // The occluders' rows: the solve's lighting basis, their visibility at a coarser resolution (only
      // their diffuse light matters).
      occluder_bounce = BuildOccluderBounce(problem.occluders, caster, std::move(occluder_samples),
                                            SolveTransportOptions(o), kOccluderBounceVisibilityResolution);
    }
    indirect = std::make_unique<IndirectLight>(transport, bounce, obs,
                                               occluder_bounce.vertices.empty() ? nullptr : &occluder_bounce);
    ctx.indirect = indirect.get();
    summary.interreflection_seconds = bounce_timer.Seconds();
    summary.interreflection_mean_sources = double(bounce.hit_vertex.size()) / std::max<size_t>(1, nv);
    summary.interreflection_occluder_vertices = occluder_bounce.vertices.size();
    RLOG_INFO("interreflection: {} x {} rays, {:.1f} source vertices per vertex, {} occluder vertices, {:.1f} s", nv,
              BounceOptions().rays_per_side * BounceOptions().rays_per_side, summary.interreflection_mean_sources,
              occluder_bounce.vertices.size(), summary.interreflection_seconds);
  }
  std::mt19937_64 rng(static_cast<uint64_t>(o.seed));
  std::uniform_real_distribution<double> uniform(0, 1);
  for (size_t k = 0; k < obs.records.size(); ++k) {
    (uniform(rng) < o.holdout_fraction ? ctx.holdout : ctx.train).push_back(static_cast<uint32_t>(k));
  }
  for (uint32_t k : ctx.train)
    if (!obs.records[k].lower_bound()) ctx.train_exact.push_back(k);
  summary.train_observations = ctx.train.size();
  summary.lower_bounds = obs.records.size();
  for (const Observation& ob : obs.records) summary.lower_bounds -= !ob.lower_bound();
  summary.holdout_observations = ctx.holdout.size();
  ctx.subset.resize(num_photos);
  for (uint32_t k : ctx.train) ctx.subset[obs.records[k].photo].push_back(k);
  for (auto& s : ctx.subset) {
    if (static_cast<int>(s.size()) > o.lighting_max_observations) {
      std::shuffle(s.begin(), s.end(), rng);
      s.resize(o.lighting_max_observations);
      std::sort(s.begin(), s.end());
    }
  }
  if (o.weight_smoothness > 0) ctx.neighbours = VertexNeighbours(problem.mesh);
  ctx.observed.assign(nv, 0);
  for (uint32_t k : ctx.train_exact) ctx.observed[obs.records[k].vertex] = 1;

  ModelSpec spec;
  spec.lobe_enabled.assign(basis.size(), 1);
  // A known reflectance (fixed or the starting point) brings its own lobes.
  if (known != nullptr && known->has_reflectance && known->reflectance.lobe_enabled.size() == basis.size())
    spec.lobe_enabled = known->reflectance.lobe_enabled;
  // A known reflectance (fixed or the starting point) brings its own materials.
  spec.materials = known != nullptr && known->has_reflectance ? known->reflectance.num_materials : o.materials;
  spec.max_iterations = o.max_iterations;
  spec.coarse_iterations = o.coarse_iterations;
  spec.init_gloss = o.init_gloss.front();
  // With known lighting only the reflectance model (materials, lobes) is selected.
  const bool can_select = o.select_model && !o.fixed_reflectance && !o.start_from_truth && !ctx.holdout.empty() &&
                          !(known != nullptr && known->has_reflectance);
  if (o.select_model && !can_select) {
    RLOG_WARN(
        "inverse.select_model needs held-out observations and a reflectance to solve from scratch (not "
        "fixed_reflectance, start_from_truth or a warm start); solving the configured model");
  }
  if (can_select) spec = SelectModel(ctx, spec, basis, total, &summary);

  // Starting points (inverse.init_gloss): each runs the whole alternation; the lowest held-out error wins.
  // A known reflectance is its own start.
  const bool known_start = known != nullptr && known->has_reflectance;
  const std::vector<double> starts = known_start ? std::vector<double>{0.0} : o.init_gloss;
  // inverse.start_race_iterations > 0: every start runs that many iterations, and only the one with
  // the lowest held-out error so far goes on (successive halving down to one).
  const bool race = starts.size() > 1 && o.start_race_iterations > 0 && o.start_race_iterations < spec.max_iterations;
  std::vector<Alternation> alternations;
  std::vector<ModelSpec> start_specs;
  std::vector<double> start_seconds(starts.size(), 0.0);
  auto start_label = [&](size_t k) {
    return starts.size() > 1 ? "alternation (start " + std::to_string(k + 1) + "/" + std::to_string(starts.size()) + ")"
                             : std::string("alternation");
  };
  for (size_t k = 0; k < starts.size(); ++k) {
    ModelSpec start_spec = spec;
    start_spec.init_gloss = starts[k];
    if (starts.size() > 1) RLOG_INFO("start {}/{}: init_gloss {}", k + 1, starts.size(), starts[k]);
    Timer start_timer;
    Alternation alt = StartAlternation(ctx, start_spec);
    ContinueAlternation(ctx, start_spec, &alt, race ? o.start_race_iterations : spec.max_iterations, start_label(k));
    start_seconds[k] = start_timer.Seconds();
    if (starts.size() > 1) {
      RLOG_INFO("start {}/{} (init_gloss {}): {} RMSE {:.5g} at iteration {}{}", k + 1, starts.size(), starts[k],
                ctx.holdout.empty() ? "training" : "held-out", alt.result.best_score, alt.result.best_iteration,
                race ? " (race)" : "");
    }
    alternations.push_back(std::move(alt));
    start_specs.push_back(start_spec);
  }
  size_t chosen_start = 0;
  for (size_t k = 1; k < starts.size(); ++k)
    if (alternations[k].result.best_score < alternations[chosen_start].result.best_score) chosen_start = k;
  if (race) {
    RLOG_INFO("start {}/{} (init_gloss {}) leads after {} iterations; continuing it", chosen_start + 1, starts.size(),
              starts[chosen_start], o.start_race_iterations);
    Timer continue_timer;
    ContinueAlternation(ctx, start_specs[chosen_start], &alternations[chosen_start], spec.max_iterations,
                        start_label(chosen_start));
    start_seconds[chosen_start] += continue_timer.Seconds();
  }
  for (size_t k = 0; k < starts.size(); ++k) {
    const AlternationResult& r = alternations[k].result;
    StartRecord rec;
    rec.init_gloss = known_start ? 0.0 : starts[k];
    rec.score = r.best_score;
    rec.best_iteration = r.best_iteration;
    rec.iterations = static_cast<int>(r.iterations.size());
    rec.seconds = start_seconds[k];
    for (const IterationRecord& it : r.iterations) {
      rec.train_rmse.push_back(it.train_rmse);
      rec.holdout_rmse.push_back(it.holdout_rmse);
      rec.solve_seconds.push_back(it.solve_seconds);
    }
    summary.starts.push_back(rec);
  }
  AlternationResult final_result = FinishAlternation(&alternations[chosen_start]);
  alternations.clear();
  summary.starts[chosen_start].chosen = true;
  result.lighting = std::move(final_result.lighting);
  result.reflectance = std::move(final_result.reflectance);
  summary.iterations = std::move(final_result.iterations);
  summary.best_iteration = final_result.best_iteration;
  summary.stop_reason = final_result.stop_reason;
  if (summary.chosen_model.empty()) summary.chosen_model = DescribeSpec(spec, basis, o.env_resolution);
  if (ctx.indirect != nullptr) {
    ctx.UpdateIndirect(result.lighting, result.reflectance);
    summary.interreflection_share = ctx.indirect->IndirectShare(ctx.train, ctx.Responses(ctx.train, result.lighting));
    RLOG_INFO("interreflection: the bounce brings {:.1f} % of the diffuse light the training observations receive",
              100 * summary.interreflection_share);
    if (ctx.indirect->has_occluders()) {
      summary.interreflection_occluder_albedo = result.reflectance.occluder_albedo;
      RLOG_INFO("interreflection: the occluders' albedo {:.3f} {:.3f} {:.3f} (relative to the object's)",
                result.reflectance.occluder_albedo[0], result.reflectance.occluder_albedo[1],
                result.reflectance.occluder_albedo[2]);
    }
  }
  if (summary.lower_bounds > 0) MeasureLowerBounds(ctx, result, &summary);
  const bool measure_resolution = o.map_resolution == "on" || (o.map_resolution == "auto" &&
                                                               (o.lighting_basis != "haar" || o.env_resolution <= 32));
  if (measure_resolution && !(o.fixed_lighting && known != nullptr && known->has_lighting)) {
    // What the photos determine of each map, under the final reflectance.
    Timer resolution_timer;
    summary.map_resolution = LightingResolution(transport, obs, ctx.subset, result.reflectance, o, result.lighting);
    summary.map_resolution_seconds = resolution_timer.Seconds();
    std::vector<double> dof;
    for (const MapResolution& m : summary.map_resolution) dof.push_back(m.dof);
    if (!dof.empty()) {
      std::nth_element(dof.begin(), dof.begin() + dof.size() / 2, dof.end());
      RLOG_INFO("the photos determine a median of {:.0f} of the {} coefficients of each map ({:.1f} s)",
                dof[dof.size() / 2],
                result.lighting.basis == "haar" ? o.env_resolution * o.env_resolution : result.lighting.dim,
                summary.map_resolution_seconds);
    }
  }
  FillUnobservedWeights(problem.mesh, ctx.observed, &result.reflectance);
  summary.seconds = total.Seconds();
  return result;
}

std::string ReadMeshSource(const std::string& mesh_dir) {
  if (mesh_dir.empty()) return "";
  const std::string path = JoinPath(mesh_dir, "mesh_summary.json");
  if (!fs::is_regular_file(path)) return "";
  const Json j = ReadJsonFile(path);
  const auto it = j.find("source");
  return it != j.end() && it->is_string() ? it->get<std::string>() : "";
}

InverseProblem ReadInverseProblem(const std::string& mesh_dir, const std::string& visibility_dir,
                                  const std::string& observe_dir) {
  const std::string mesh = JoinPath(mesh_dir, "mesh.ply"), vis = JoinPath(visibility_dir, "visibility.bin"),
                    obs = JoinPath(observe_dir, "observations.bin"), photos = JoinPath(observe_dir, "photos.json");
  for (const std::string& path : {mesh, vis, obs, photos})
    if (!fs::is_regular_file(path))
      RELIGHT_USER_ERROR() << "'" << path << "' is missing; rerun the stage that writes it";
  InverseProblem p;
  p.mesh = ReadMesh(mesh);
  if (p.mesh.normals.size() != p.mesh.num_vertices()) p.mesh.ComputeVertexNormals();
  if (const std::string occluders = JoinPath(mesh_dir, "occluders.ply"); fs::is_regular_file(occluders)) {
    p.occluders = ReadMesh(occluders);
    if (p.occluders.normals.size() != p.occluders.num_vertices()) p.occluders.ComputeVertexNormals();
  }
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

namespace {

// Per-photo numbers of the recovered maps, for the medians in solve_summary.json.
struct LightingStats {
  std::vector<double> coefficients_99;              // per photo (haar)
  std::vector<double> determined, resolved_detail;  // per photo (LightingResolution)
};

// Brightest direction of an octahedral map (texel of largest luminance), world frame.
Eigen::Vector3d BrightestDirection(const Image& oct, int n_out) {
  int best = 0;
  double best_lum = -1;
  for (int k = 0; k < n_out * n_out; ++k) {
    const double lum = Luminance(&oct.pixels[k * 3]);
    if (lum > best_lum) {
      best_lum = lum;
      best = k;
    }
  }
  return OctTexelDirection(best % n_out, best / n_out, n_out);
}

// How many wavelet coefficients the map uses: the fewest holding 99% of its luminance's
// detail energy (the mean, coefficient 0, left out).
size_t HaarCoefficients99(const Image& oct, int n_out) {
  std::vector<float> lum(size_t(n_out) * n_out);
  for (size_t k = 0; k < lum.size(); ++k)
    lum[k] =
        static_cast<float>(Luminance(Eigen::Vector3d(oct.pixels[k * 3], oct.pixels[k * 3 + 1], oct.pixels[k * 3 + 2])));
  HaarForward(lum.data(), n_out, lum.data());
  lum[0] = 0.0f;
  return KeepEnergy(lum.data(), n_out, 0.99).size();
}

// Which directions the photos see, which the priors fill (envmaps/<stem>_determined.png, white: the photos'), and the
// daylight model fitted to what the photos determine (and how much of it that model explains), into the photo's
// lighting.json entry.
void WriteDataShare(const MapResolution& m, const Image& oct, int n_out, const std::string& stem,
                    const std::string& output_dir, Json* entry) {
  Image share(n_out, n_out, 1);
  double mean = 0;
  for (size_t k = 0; k < m.data_share.size(); ++k) {
    share.pixels[k] = std::clamp(m.data_share[k], 0.0f, 1.0f);
    mean += share.pixels[k] / double(m.data_share.size());
  }
  const std::string png = "envmaps/" + stem + "_determined.png";
  WriteImage(JoinPath(output_dir, png), share);
  (*entry)["determined_map"] = png;
  (*entry)["data_share_mean"] = mean;
  // The daylight model fitted to what the photos determine: the sun's direction to sub-texel precision.
  std::array<std::vector<double>, 3> rgb;
  for (int c = 0; c < 3; ++c) {
    rgb[c].resize(m.data_share.size());
    for (size_t k = 0; k < rgb[c].size(); ++k) rgb[c][k] = oct.pixels[k * 3 + c];
  }
  const NaturalLight sky = FitNaturalLight({rgb[0].data(), rgb[1].data(), rgb[2].data()},
                                           std::vector<double>(m.data_share.begin(), m.data_share.end()), n_out);
  const Eigen::Vector3d& sun = sky.sun_dir_world;
  (*entry)["sun"] = {{"direction_world", {sun.x(), sun.y(), sun.z()}},
                     {"elevation_deg", std::asin(std::clamp(sun.z(), -1.0, 1.0)) * 180.0 / M_PI},
                     {"irradiance_share", sky.sun_irradiance_share},
                     {"daylight_explained_variation", sky.explained_variation}};
}

// One photo's maps (envmaps/<stem>_oct.exr, _latlong.exr, _determined.png) and its lighting.json entry; its numbers
// into `stats`.
Json WritePhotoLighting(const InverseOptions& o, const ObservedPhoto& photo, const InverseResult& result, int n_out,
                        const std::string& output_dir, LightingStats* stats) {
  const std::string stem = fs::path(photo.name).stem().string();
  const std::vector<float> rgb = result.lighting.OctahedralRgb(static_cast<int>(photo.index), n_out);
  Image oct(n_out, n_out, 3);
  for (size_t k = 0; k < rgb.size(); ++k) oct.pixels[k] = rgb[k];
  const LightingState& lighting = result.lighting;
  const bool solved_sun = lighting.basis == "haar" && n_out == lighting.env_resolution && lighting.has_sun(photo.index);
  if (solved_sun) {
    // A sun solved as its own light is held as its bilinear splat, the transport's view of a delta; the
    // exported map, like a photographed map averaged over texels, has it in the one texel around its direction.
    const Eigen::Vector3d& d = lighting.sun_dir_world[photo.index];
    const Eigen::Vector3d& e = lighting.sun_irradiance[photo.index];
    for (const auto& [k, v] : SunSplat(d, n_out))
      for (int c = 0; c < 3; ++c) oct.pixels[size_t(k) * 3 + c] -= static_cast<float>(e[c] * v);
    const Eigen::Vector2i t = OctTexelOf(d, n_out);
    const double omega = OctTexelSolidAngle(t.x(), t.y(), n_out);
    for (int c = 0; c < 3; ++c) oct.at(t.x(), t.y(), c) += static_cast<float>(e[c] / omega);
  }
  for (float& v : oct.pixels) v = std::max(0.0f, v);
  WriteImage(JoinPath(output_dir, "envmaps/" + stem + "_oct.exr"), oct, {PixelType::kFloat});
  const EnvMap env = EnvMap::FromOctahedral(oct);
  WriteImage(JoinPath(output_dir, "envmaps/" + stem + "_latlong.exr"), env.ToLatLong(std::max(32, 2 * n_out), 0),
             {PixelType::kFloat});
  const Eigen::Vector3d dir = BrightestDirection(oct, n_out);
  Json entry = {{"index", photo.index},
                {"name", photo.name},
                {"envmap_oct", "envmaps/" + stem + "_oct.exr"},
                {"envmap_latlong", "envmaps/" + stem + "_latlong.exr"},
                {"brightest_direction_world", {dir.x(), dir.y(), dir.z()}}};
  if (photo.index < lighting.daylight_fill.size()) entry["daylight_fill"] = lighting.daylight_fill[photo.index];
  if (o.lighting_basis == "haar") {
    const size_t used = HaarCoefficients99(oct, n_out);
    entry["haar_coefficients_99"] = used;
    stats->coefficients_99.push_back(static_cast<double>(used));
  }
  if (photo.index < result.summary.map_resolution.size()) {
    // What the photos determine of this map (LightingResolution).
    const MapResolution& m = result.summary.map_resolution[photo.index];
    entry["determined_coefficients"] = m.dof;
    entry["determined_per_level"] = m.dof_per_level;
    entry["coefficients_per_level"] = m.coefficients_per_level;
    const double detail = ResolvedDetailDegrees(m, o.lighting_basis);
    entry["resolved_detail_deg"] = detail > 0 ? Json(detail) : Json();
    if (m.data_share.size() == size_t(n_out) * n_out) WriteDataShare(m, oct, n_out, stem, output_dir, &entry);
    if (solved_sun) {
      const Eigen::Vector3d& d = lighting.sun_dir_world[photo.index];
      const Eigen::Vector3d& e = lighting.sun_irradiance[photo.index];
      entry["sun"]["direction_world"] = {d.x(), d.y(), d.z()};
      entry["sun"]["elevation_deg"] = std::asin(std::clamp(d.z(), -1.0, 1.0)) * 180.0 / M_PI;
      entry["sun"]["irradiance_rgb"] = {e.x(), e.y(), e.z()};
    }
    stats->determined.push_back(m.dof);
    if (detail > 0) stats->resolved_detail.push_back(detail);
  }
  return entry;
}

// envmaps/ and lighting.json; returns the per-photo numbers.
LightingStats WriteLighting(const InverseOptions& o, const InverseProblem& problem, const InverseResult& result,
                            const std::string& output_dir) {
  EnsureDir(JoinPath(output_dir, "envmaps"));
  const int n_out = o.lighting_basis == "haar" ? o.env_resolution : 32;
  LightingStats stats;
  Json photos_json = Json::array();
  for (const auto& photo : problem.photos)
    photos_json.push_back(WritePhotoLighting(o, photo, result, n_out, output_dir, &stats));
  WriteJsonAtomic(JoinPath(output_dir, "lighting.json"), [&] {
    Json j{{"basis", o.lighting_basis}, {"env_resolution", n_out}, {"photos", photos_json}};
    // Relight renders the bounce the maps were solved with.
    if (o.interreflection != "off") {
      j["interreflection"] = Json{{"rays_per_side", BounceOptions().rays_per_side}};
      if (result.summary.interreflection_occluder_vertices > 0) {
        const Eigen::Vector3d& a = result.reflectance.occluder_albedo;
        j["interreflection"]["occluder_albedo"] = {a[0], a[1], a[2]};
      }
    }
    return j;
  }());
  return stats;
}

// reflectance.ply (the mesh with per-vertex material weights and diffuse albedo) and materials.json.
void WriteReflectance(const TriangleMesh& mesh, const ReflectanceState& r, const std::string& output_dir) {
  TriangleMesh out = mesh;
  const ReflectanceModel model = r.Model();
  for (int m = 0; m < r.num_materials; ++m) {
    std::vector<float>& w = out.Property("w" + std::to_string(m));
    for (size_t v = 0; v < out.num_vertices(); ++v) w[v] = r.weights[v * r.num_materials + m];
  }
  std::vector<float>&ar = out.Property("albedo_r"), &ag = out.Property("albedo_g"), &ab = out.Property("albedo_b");
  for (size_t v = 0; v < out.num_vertices(); ++v) {
    std::vector<double> w(r.weights.begin() + v * r.num_materials, r.weights.begin() + (v + 1) * r.num_materials);
    const Eigen::Vector3d albedo = model.DiffuseAlbedo(w);
    ar[v] = static_cast<float>(albedo.x());
    ag[v] = static_cast<float>(albedo.y());
    ab[v] = static_cast<float>(albedo.z());
  }
  WriteMeshPly(JoinPath(output_dir, "reflectance.ply"), out);
  WriteReflectanceModel(JoinPath(output_dir, "materials.json"), model);
}

// solve_summary.json's "iterations".
Json IterationsJson(const std::vector<IterationRecord>& iterations) {
  Json iters = Json::array();
  for (const auto& it : iterations) {
    iters.push_back({{"iteration", it.iteration},
                     {"objective", it.objective},
                     {"train_rmse", it.train_rmse},
                     {"holdout_rmse", it.holdout_rmse},
                     {"lighting_seconds", it.lighting_seconds},
                     {"reflectance_seconds", it.reflectance_seconds},
                     {"solve_seconds", it.solve_seconds},
                     {"photo_rmse", it.photo_rmse}});
  }
  return iters;
}

// solve_summary.json's "starts".
Json StartsJson(const std::vector<StartRecord>& starts) {
  Json out = Json::array();
  for (const auto& st : starts) {
    out.push_back({{"init_gloss", st.init_gloss},
                   {"score", st.score},
                   {"best_iteration", st.best_iteration},
                   {"iterations", st.iterations},
                   {"seconds", st.seconds},
                   {"train_rmse", st.train_rmse},
                   {"holdout_rmse", st.holdout_rmse},
                   {"solve_seconds", st.solve_seconds},
                   {"chosen", st.chosen}});
  }
  return out;
}

// solve_summary.json's "model_selection" candidates.
Json CandidatesJson(const std::vector<ModelCandidate>& candidates) {
  Json cands = Json::array();
  for (const auto& c : candidates) {
    cands.push_back({{"stage", c.stage},
                     {"model", c.description},
                     {"materials", c.materials},
                     {"basis", c.basis},
                     {"env_resolution", c.env_resolution},
                     {"holdout_rmse", c.holdout_rmse},
                     {"train_rmse", c.train_rmse},
                     {"seconds", c.seconds},
                     {"solve_seconds", c.solve_seconds},
                     {"chosen", c.chosen}});
  }
  return cands;
}

// solve_summary.json: the problem's size, the solve's summary and the medians of the per-photo numbers.
void WriteSolveSummary(const InverseOptions& o, const InverseProblem& problem, const InverseResult& result,
                       const LightingStats& stats, const std::string& output_dir) {
  const InverseSummary& s = result.summary;
  OrderedJson j;
  j["lighting_basis"] = o.lighting_basis;
  j["env_resolution"] = o.env_resolution;
  j["sh_order"] = o.sh_order;
  j["basis"] = o.basis;
  j["materials"] = result.reflectance.num_materials;
  j["photos"] = problem.photos.size();
  j["vertices"] = problem.mesh.num_vertices();
  j["observations"] = problem.observations.records.size();
  j["train_observations"] = s.train_observations;
  j["holdout_observations"] = s.holdout_observations;
  j["lower_bounds"] = s.lower_bounds;
  if (s.lower_bounds > 0) {
    j["lower_bounds_missed"] = s.lower_bounds_missed;
    j["lower_bounds_mean_shortfall"] = s.lower_bounds_mean_shortfall;
  }
  j["transport_seconds"] = s.transport_seconds;
  if (s.interreflection_seconds > 0) {
    j["interreflection"] = {{"seconds", s.interreflection_seconds},
                            {"mean_source_vertices", s.interreflection_mean_sources},
                            {"indirect_share", s.interreflection_share},
                            {"occluder_vertices", s.interreflection_occluder_vertices}};
    if (s.interreflection_occluder_vertices > 0) {
      const Eigen::Vector3d& a = s.interreflection_occluder_albedo;
      j["interreflection"]["occluder_albedo"] = {a[0], a[1], a[2]};
    }
  }
  j["transport_footprint"] = s.transport_footprint;
  j["transport_mean_coefficients_per_row"] = s.transport_mean_coefficients_per_row;
  j["iterations"] = IterationsJson(s.iterations);
  j["best_iteration"] = s.best_iteration;
  j["stop_reason"] = s.stop_reason;
  j["model"] = s.chosen_model;
  j["starts"] = StartsJson(s.starts);
  if (!s.candidates.empty())
    j["model_selection"] = {{"seconds", s.selection_seconds}, {"candidates", CandidatesJson(s.candidates)}};
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  if (!stats.coefficients_99.empty()) j["lighting_coefficients_99_median"] = median(stats.coefficients_99);
  if (!stats.determined.empty()) {
    j["lighting_determined_coefficients_median"] = median(stats.determined);
    j["map_resolution_seconds"] = s.map_resolution_seconds;
  }
  if (!stats.resolved_detail.empty()) j["lighting_resolved_detail_deg_median"] = median(stats.resolved_detail);
  j["gauge"] = o.gauge;
  j["seconds"] = s.seconds;
  WriteJsonAtomic(JoinPath(output_dir, "solve_summary.json"), j);
}

}  // namespace

InverseSummary RunInverse(const InverseOptions& o, InverseProblem& problem, const KnownQuantities& known,
                          const std::string& output_dir) {
  problem.scratch_dir = output_dir;
  const InverseResult result = SolveInverse(problem, o, &known);

  // Outputs.
  const LightingStats stats = WriteLighting(o, problem, result, output_dir);
  WriteReflectance(problem.mesh, result.reflectance, output_dir);
  WriteSolveSummary(o, problem, result, stats, output_dir);
  return result.summary;
}

std::string InverseSummary::BriefReport() const {
  std::string s = fmt::format("inverse: model {}, {} iterations ({}), best {}", chosen_model, iterations.size(),
                              stop_reason, best_iteration);
  for (const IterationRecord& r : iterations) {
    if (r.iteration == best_iteration) {
      s += fmt::format(" (RMSE train {:.4g}, held out {:.4g})", r.train_rmse, r.holdout_rmse);
    }
  }
  s += fmt::format("; {} training and {} held-out observations", train_observations, holdout_observations);
  if (interreflection_mean_sources > 0)
    s += fmt::format("; the bounce {:.1f} % of the diffuse light", 100 * interreflection_share);
  return s + "; " + Progress::FormatSeconds(seconds);
}

}  // namespace relight
