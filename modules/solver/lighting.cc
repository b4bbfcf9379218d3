#include "solver/lighting.h"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>

#include "core/error.h"
#include "core/timer.h"
#include "image/color.h"
#include "solver/natural_light.h"
#include "solver/qp.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "wavelet/haar.h"

namespace relight {

Eigen::MatrixXd OctahedralLaplacianGram(int n) {
  const int dim = n * n;
  Eigen::MatrixXd lap = Eigen::MatrixXd::Zero(dim, dim);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int k = j * n + i;
      const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
      for (int q = 0; q < 4; ++q) {
        const Eigen::Vector2i t = OctWrapTexel(i + di[q], j + dj[q], n);
        const int nb = t.y() * n + t.x();
        if (nb == k) continue;
        lap(k, k) += 1.0;
        lap(k, nb) -= 1.0;
      }
    }
  }
  return lap.transpose() * lap;
}

std::vector<double> RobustWeights(const std::vector<double>& residuals, const std::string& loss, double scale) {
  std::vector<double> w(residuals.size(), 1.0);
  if (loss == "none" || residuals.empty()) return w;
  std::vector<double> abs_r(residuals.size());
  for (size_t k = 0; k < residuals.size(); ++k) abs_r[k] = std::abs(residuals[k]);
  std::vector<double> sorted = abs_r;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double sigma = 1.4826 * sorted[sorted.size() / 2];
  const double s = std::max(1e-12, scale * sigma);
  for (size_t k = 0; k < residuals.size(); ++k) {
    const double r = abs_r[k] / s;
    w[k] = loss == "huber" ? (r <= 1 ? 1.0 : 1.0 / r) : 1.0 / (1.0 + r * r);
  }
  return w;
}

std::vector<std::pair<int, double>> SunSplat(const Eigen::Vector3d& dir_world, int n) {
  const Eigen::Vector2d st = OctEncode(dir_world);
  const double u = st.x() * n - 0.5, v = st.y() * n - 0.5;
  const int i0 = static_cast<int>(std::floor(u)), j0 = static_cast<int>(std::floor(v));
  const double fu = u - i0, fv = v - j0;
  std::vector<std::pair<int, double>> out;
  for (int b = 0; b <= 1; ++b)
    for (int a = 0; a <= 1; ++a) {
      const double w = (a ? fu : 1 - fu) * (b ? fv : 1 - fv);
      if (w <= 0) continue;
      // One step past a border is the neighbour across the fold; past a corner, fold twice.
      Eigen::Vector2i t = OctWrapTexel(i0 + a, j0 + b, n);
      t = OctWrapTexel(t.x(), t.y(), n);
      const int k = t.y() * n + t.x();
      const double value = w / OctTexelSolidAngle(t.x(), t.y(), n);
      auto it = std::find_if(out.begin(), out.end(), [&](const auto& e) { return e.first == k; });
      if (it != out.end()) {
        it->second += value;
      } else {
        out.push_back({k, value});
      }
    }
  return out;
}

namespace {

// The orthonormal Haar basis functions of an n x n map (wavelet/haar.h), as
// sparse pixel vectors: basis[k] lists (pixel, value) of coefficient k.
struct SparseHaarBasis {
  std::vector<std::vector<std::pair<int, double>>> functions;
};

const SparseHaarBasis& HaarBasisOf(int n) {
  static std::mutex mutex;
  static std::map<int, SparseHaarBasis> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  SparseHaarBasis& basis = cache[n];
  const int dim = n * n;
  basis.functions.resize(dim);
  std::vector<double> unit(dim), pixels(dim);
  for (int k = 0; k < dim; ++k) {
    std::fill(unit.begin(), unit.end(), 0.0);
    unit[k] = 1.0;
    HaarInverse(unit.data(), n, pixels.data());
    for (int p = 0; p < dim; ++p)
      if (pixels[p] != 0.0) basis.functions[k].push_back({p, pixels[p]});
  }
  return basis;
}

}  // namespace

Eigen::MatrixXd HaarL1Penalty(const std::array<const float*, 3>& maps, int n, double floor_fraction) {
  const int dim = n * n;
  Eigen::MatrixXd penalty = Eigen::MatrixXd::Zero(dim, dim);
  std::array<std::vector<double>, 3> coeffs;
  double mean = 0;
  for (int c = 0; c < 3; ++c) {
    coeffs[c].assign(maps[c], maps[c] + dim);
    HaarForward(coeffs[c].data(), n, coeffs[c].data());
    mean += coeffs[c][0] / n / 3.0;  // index 0 is n * the map's mean
  }
  if (!(mean > 0)) return penalty;  // no map yet: nothing to reweight from
  const SparseHaarBasis& basis = HaarBasisOf(n);
  const double floor = floor_fraction * mean;
  for (int k = 1; k < dim; ++k) {  // the scaling coefficient (the mean) is not penalised
    double g2 = 0;
    for (int c = 0; c < 3; ++c) g2 += coeffs[c][k] * coeffs[c][k];
    const double weight = mean / std::max(floor, std::sqrt(g2 / 3.0));
    const auto& f = basis.functions[k];
    for (const auto& [p, vp] : f)
      for (const auto& [q, vq] : f) penalty(p, q) += weight * vp * vq;
  }
  return penalty;
}

namespace {

// Active-set rounds for lower bounds per channel and reweighting pass (each a QP solve).
constexpr int kMaxBoundRounds = 16;

// Non-negativity at sample directions for SH lighting: exact-penalty active set.
Eigen::VectorXd SolveShNonNegative(const Eigen::MatrixXd& Q, const Eigen::VectorXd& q, const Eigen::MatrixXd& basis,
                                   int* iterations) {
  const double mu = 1e3 * std::max(1e-30, Q.diagonal().maxCoeff());
  Eigen::VectorXd x = Eigen::LDLT<Eigen::MatrixXd>(Q).solve(q);
  std::vector<char> active(basis.rows(), 0);
  *iterations = 1;
  for (int iter = 0; iter < 40; ++iter) {
    const Eigen::VectorXd p = basis * x;
    std::vector<char> next(basis.rows(), 0);
    bool changed = false;
    for (Eigen::Index k = 0; k < p.size(); ++k) {
      next[k] = p[k] < 0 || (active[k] && p[k] <= 1e-12);
      changed |= next[k] != active[k];
    }
    if (!changed) break;
    active = next;
    Eigen::MatrixXd h = Q;
    for (Eigen::Index k = 0; k < p.size(); ++k)
      if (active[k]) h.selfadjointView<Eigen::Lower>().rankUpdate(basis.row(k).transpose(), mu);
    h = h.selfadjointView<Eigen::Lower>();
    x = Eigen::LDLT<Eigen::MatrixXd>(h).solve(q);
    ++*iterations;
  }
  return x;
}

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// One photo's lighting system at solve resolution n ≤ n_full (Haar: a coarse
// solve keeps the top-left n × n block of the coefficients, see lighting.h):
// per channel the rows a (pixel domain for Haar, SH coefficients otherwise)
// and measurements y, the confidences and the lower-bound flags
// (kObservationLowerBound) per row and channel.
struct PhotoSystem {
  std::array<RowMatrix, 3> a;
  std::array<Eigen::VectorXf, 3> y;
  Eigen::VectorXd alpha;
  std::vector<char> lower;
};

PhotoSystem AssemblePhotoSystem(const TransportStore& transport, const ObservationSet& observations,
                                const std::vector<uint32_t>& obs, const ReflectanceState& reflectance, bool haar,
                                int n_full, int n, int dim) {
  const int block = haar ? n_full / n : 1;
  const float coarse_scale = static_cast<float>(block);  // Haar coefficient ratio between the two grids
  const int num_lobes = reflectance.num_lobes();
  const Eigen::Index rows = static_cast<Eigen::Index>(obs.size());
  PhotoSystem sys;
  sys.alpha.resize(rows);
  sys.lower.assign(rows * 3, 0);
  for (int c = 0; c < 3; ++c) {
    sys.a[c] = RowMatrix::Zero(rows, dim);
    sys.y[c].resize(rows);
  }
  std::vector<float> rho(num_lobes * 3);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const size_t o = obs[r];
    const Observation& ob = observations.records[o];
    reflectance.VertexLobeWeights(ob.vertex, rho.data());
    sys.alpha[r] = ob.confidence;
    for (int c = 0; c < 3; ++c) sys.lower[r * 3 + c] = ob.lower_bound(c);
    for (int c = 0; c < 3; ++c) sys.y[c][r] = ob.rgb[c];
    for (int b = 0; b < num_lobes; ++b) {
      const TransportStore::Row row = transport.Get(o, ob.vertex, b);
      for (int c = 0; c < 3; ++c) {
        const float s = rho[b * 3 + c];
        if (s == 0.0f) continue;
        float* dst = sys.a[c].row(r).data();
        if (block == 1) {
          for (uint32_t k = 0; k < row.size; ++k) dst[row.index[k]] += s * row.value[k];
        } else {
          for (uint32_t k = 0; k < row.size; ++k) {
            const int rr = row.index[k] / n_full, cc = row.index[k] % n_full;
            if (rr < n && cc < n) dst[rr * n + cc] += s * coarse_scale * row.value[k];
          }
        }
      }
    }
    if (haar) {
      for (int c = 0; c < 3; ++c) HaarInverse(sys.a[c].row(r).data(), n, sys.a[c].row(r).data());
    }
  }
  // The photo's rows are in the system now (rows on disk leave the resident set).
  if (!obs.empty())
    transport.Evict(*std::min_element(obs.begin(), obs.end()), *std::max_element(obs.begin(), obs.end()) + 1);
  return sys;
}

// Mean of a texel's four neighbours on an n×n octahedral map (fold rule).
double NeighbourMean(const Eigen::VectorXd& x, int k, int n) {
  const int i = k % n, j = k / n;
  const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
  double sum = 0;
  for (int q = 0; q < 4; ++q) {
    const Eigen::Vector2i t = OctWrapTexel(i + di[q], j + dj[q], n);
    sum += x[t.y() * n + t.x()];
  }
  return sum / 4;
}

// The natural-light prior's pull of every texel towards the daylight model, relative to the Laplacian's
// weight (whose Gram has about 20 on its diagonal): weak beside any observation, decisive where there is none.
constexpr double kNaturalLightPull = 1.0;

// The smoothness prior per unit weight: the octahedral Laplacian's Gram (Haar)
// or the diagonal (l(l+1))² over SH bands.
Eigen::MatrixXd SmoothnessRegularizer(const LightingState& lighting, int n) {
  if (lighting.basis == "haar") return OctahedralLaplacianGram(n);
  Eigen::MatrixXd regularizer = Eigen::MatrixXd::Zero(lighting.dim, lighting.dim);
  for (int l = 0; l <= lighting.sh_order; ++l)
    for (int m = -l; m <= l; ++m) regularizer(ShIndex(l, m), ShIndex(l, m)) = double(l * (l + 1)) * (l * (l + 1));
  return regularizer;
}

}  // namespace

double DaylightFillWeight(double explained_variation) {
  const double t = std::clamp(
      (explained_variation - kDaylightFillExplainedFrom) / (kDaylightFillExplainedTo - kDaylightFillExplainedFrom), 0.0,
      1.0);
  return t * t * (3 - 2 * t);  // smoothstep: no kink at either end
}

LightingStepResult SolveLighting(const TransportStore& transport, const ObservationSet& observations,
                                 const std::vector<std::vector<uint32_t>>& subset, const ReflectanceState& reflectance,
                                 const InverseOptions& options, LightingState* lighting, int solve_resolution) {
  Timer timer;
  const bool haar = lighting->basis == "haar";
  const int n_full = lighting->env_resolution;
  // Coarse solves use the top-left block of the Haar layout (see the header).
  const int n = haar && solve_resolution > 0 ? std::min(solve_resolution, n_full) : n_full;
  const int block = n_full / n;  // fine texels per coarse texel side
  const int dim = haar ? n * n : lighting->dim;
  const int num_photos = static_cast<int>(subset.size());
  lighting->sun_dir_world.resize(lighting->values.size(), Eigen::Vector3d::UnitZ());
  lighting->sun_irradiance.resize(lighting->values.size(), Eigen::Vector3d::Zero());
  LightingStepResult result;
  result.photo_rmse.assign(num_photos, 0.0);
  result.qp_iterations.assign(num_photos, 0);

  const Eigen::MatrixXd regularizer = SmoothnessRegularizer(*lighting, n);  // per unit weight
  const bool natural_option = haar && options.light_prior == "natural";
  if (natural_option) lighting->daylight_fill.assign(lighting->values.size(), 1.0f);
  Eigen::MatrixXd sh_constraint;
  if (!haar) {
    const int nc = 32;
    sh_constraint.resize(nc * nc, dim);
    for (int k = 0; k < nc * nc; ++k) {
      const Eigen::VectorXd y = ShEvaluate(lighting->sh_order, OctTexelDirection(k % nc, k / nc, nc));
      sh_constraint.row(k) = y.transpose();
    }
  }

  tbb::parallel_for(0, num_photos, [&](int i) {
    const std::vector<uint32_t>& obs = subset[i];
    const Eigen::Index rows = static_cast<Eigen::Index>(obs.size());
    if (rows == 0) return;
    PhotoSystem sys = AssemblePhotoSystem(transport, observations, obs, reflectance, haar, n_full, n, dim);
    const std::array<RowMatrix, 3>& a = sys.a;
    const std::array<Eigen::VectorXf, 3>& y = sys.y;
    const Eigen::VectorXd& alpha = sys.alpha;
    const std::vector<char>& lower = sys.lower;

    std::vector<double> robust(rows, 1.0);
    std::array<std::vector<Eigen::Index>, 3> exact_rows, bound_rows;  // per channel
    for (Eigen::Index r = 0; r < rows; ++r)
      for (int c = 0; c < 3; ++c) (lower[r * 3 + c] ? bound_rows[c] : exact_rows[c]).push_back(r);
    // Σ w a aᵀ (lower triangle) and Σ w y a over the listed rows of channel c.
    auto accumulate = [&](int c, const std::vector<Eigen::Index>& list, Eigen::MatrixXd* q, Eigen::VectorXd* rhs) {
      RowMatrix aw(static_cast<Eigen::Index>(list.size()), dim);
      Eigen::VectorXf yw(static_cast<Eigen::Index>(list.size()));
      for (size_t k = 0; k < list.size(); ++k) {
        const Eigen::Index r = list[k];
        const float sw = static_cast<float>(std::sqrt(alpha[r] * robust[r]));
        aw.row(static_cast<Eigen::Index>(k)) = sw * a[c].row(r);
        yw[static_cast<Eigen::Index>(k)] = sw * y[c][r];
      }
      Eigen::MatrixXf qf = Eigen::MatrixXf::Zero(dim, dim);
      qf.selfadjointView<Eigen::Lower>().rankUpdate(aw.transpose());
      *q = Eigen::MatrixXd(qf.cast<double>().selfadjointView<Eigen::Lower>());
      *rhs = (aw.transpose() * yw).cast<double>();
    };
    // One pass more when the map turns out a clear sky without its sun split out yet (the split starts from a map).
    int passes = options.irls_iterations;
    for (int pass = 0; pass < passes; ++pass) {
      std::vector<double> residual(rows, 0.0);
      double sse = 0, wsum = 0;
      // Warm start: the current map, block-averaged to the solve resolution, the last step's sun (if any) taken
      // out (it starts its own variable).
      std::array<Eigen::VectorXd, 3> start;
      std::array<double, 3> sun_start{0, 0, 0};
      const bool had_sun = lighting->has_sun(i);
      const std::vector<std::pair<int, double>> old_splat =
          had_sun ? SunSplat(lighting->sun_dir_world[i], n_full) : std::vector<std::pair<int, double>>();
      for (int c = 0; c < 3; ++c) {
        Eigen::VectorXd full =
            Eigen::Map<const Eigen::VectorXf>(lighting->values[i][c].data(), n_full * n_full).cast<double>();
        if (had_sun) {
          sun_start[c] = lighting->sun_irradiance[i][c];
          for (const auto& [k, v] : old_splat) full[k] = std::max(0.0, full[k] - sun_start[c] * v);
        }
        Eigen::VectorXd& x = start[c];
        x.resize(dim);
        if (block == 1) {
          x = full;
        } else {
          for (int k = 0; k < dim; ++k) {
            double sum = 0;
            const int i0 = (k % n) * block, j0 = (k / n) * block;
            for (int dj = 0; dj < block; ++dj)
              for (int di = 0; di < block; ++di) sum += full[(j0 + dj) * n_full + i0 + di];
            x[k] = sum / (block * block);
          }
        }
      }
      // The data term's diagonal per channel (every row, bounds included): λ from its largest value,
      // so λ does not move with the active set, and the natural-light prior's texel weights.
      std::array<Eigen::VectorXd, 3> diagonal;
      for (int c = 0; c < 3; ++c) {
        diagonal[c] = Eigen::VectorXd::Zero(dim);
        for (Eigen::Index r = 0; r < rows; ++r)
          diagonal[c] += (alpha[r] * robust[r]) * a[c].row(r).cast<double>().cwiseAbs2().transpose();
      }
      // The natural-light prior: the priors act on the map's departure from a daylight model fitted to what
      // the photos determine of the current map (each texel weighted by the photos' share of its curvature),
      // and a weak pull towards the model fills the directions no observation sees with its sky and ground.
      // The whole map, the warm start's sun put back as the rows see it (its splat): where the sun's direction is
      // read, and the start when the sun is not split out this time. The daylight model is fitted to the map as
      // it is exported, the sun in the one texel around its direction, as the model's sun term describes it.
      std::array<Eigen::VectorXd, 3> whole = start, exported = start;
      if (had_sun) {
        for (const auto& [k, v] : SunSplat(lighting->sun_dir_world[i], n))
          for (int c = 0; c < 3; ++c) whole[c][k] += sun_start[c] * v;
        const Eigen::Vector2i t = OctTexelOf(lighting->sun_dir_world[i], n);
        const double omega = OctTexelSolidAngle(t.x(), t.y(), n);
        for (int c = 0; c < 3; ++c) exported[c][t.y() * n + t.x()] += sun_start[c] / omega;
      }
      std::array<Eigen::VectorXd, 3> model_map;
      // The sun as its own variable (see the header): its splat at the solve resolution, per unit irradiance.
      bool split_sun = false;
      Eigen::Vector3d sun_dir = Eigen::Vector3d::UnitZ();
      std::vector<std::pair<int, double>> splat;
      std::vector<double> share(dim, 0.0);
      auto clear_sky = [&](const NaturalLight& model) {
        // At the maps' own resolution only: a coarse solve's texels are too wide to tell a disc from an aureole.
        return block == 1 && model.explained_variation >= kSunSplitExplained &&
               model.sun_irradiance_share >= kSunSplitShare && model.sun_disc_share >= kSunSplitDiscShare;
      };
      // How much the daylight model fills this photo's map (DaylightFillWeight), from the map the pass starts from.
      bool natural = natural_option;
      double fill = 0;
      NaturalLight model;
      if (natural) {
        for (int c = 0; c < 3; ++c) {
          const double lambda_c = options.smoothness * std::max(1e-30, diagonal[c].maxCoeff());
          for (int k = 0; k < dim; ++k)
            share[k] += diagonal[c][k] / (diagonal[c][k] + lambda_c * regularizer(k, k)) / 3.0;
        }
        model = FitNaturalLight({exported[0].data(), exported[1].data(), exported[2].data()}, share, n);
        fill = DaylightFillWeight(model.explained_variation);
        lighting->daylight_fill[i] = static_cast<float>(fill);
        natural = fill > 0;
      }
      if (natural) {
        // A clear sky's sun (most of the model's light from the sun, most of that from its disc): the sun,
        // where the map's light concentrates, becomes its own variable.
        if (clear_sky(model)) {
          split_sun = true;
          std::vector<double> luminance(dim);
          for (int k = 0; k < dim; ++k)
            luminance[k] = Luminance(Eigen::Vector3d(whole[0][k], whole[1][k], whole[2][k]));
          sun_dir = CompactLobeDirection(luminance, n);
          splat = SunSplat(sun_dir, n);
          // The prior's model without its sun: the sun is the variable's, the priors hold the sky.
          for (int c = 0; c < 3; ++c) model.coefficients[c][3] = 0;
        }
        std::array<std::vector<double>, 3> m = model.Octahedral(n);
        for (int c = 0; c < 3; ++c) model_map[c] = fill * Eigen::Map<const Eigen::VectorXd>(m[c].data(), dim);
      }
      if (!split_sun) {
        lighting->sun_irradiance[i].setZero();
        start = whole;
        sun_start = {0, 0, 0};
      }
      // Group-sparse Haar prior, reweighted from the warm start (IRLS on the L1 norm).
      Eigen::MatrixXd sparsity_penalty;
      if (haar && options.wavelet_sparsity > 0) {
        std::array<std::vector<float>, 3> maps;
        for (int c = 0; c < 3; ++c) {
          maps[c].resize(dim);
          for (int k = 0; k < dim; ++k) maps[c][k] = static_cast<float>(start[c][k] - (natural ? model_map[c][k] : 0.0));
        }
        sparsity_penalty =
            HaarL1Penalty({maps[0].data(), maps[1].data(), maps[2].data()}, n, options.wavelet_sparsity_floor);
      }
      for (int c = 0; c < 3; ++c) {
        Eigen::VectorXd x = start[c];
        // The sun's irradiance; without a sun last step, the warm start's excess at the sun over the map's
        // level around it.
        double sun = sun_start[c];
        if (split_sun && !had_sun) {
          double excess = 0;
          for (const auto& [k, v] : splat) {
            const double level = NeighbourMean(x, k, n);
            excess += std::max(0.0, x[k] - level) / v / splat.size();
            x[k] = std::min(x[k], level);
          }
          sun = excess;
        }
        // Map plus sun as the rows see them.
        auto with_sun = [&](const Eigen::VectorXd& sky) {
          Eigen::VectorXd total = sky;
          for (const auto& [k, v] : splat) total[k] += sun * v;
          return total;
        };
        Eigen::MatrixXd q_exact;
        Eigen::VectorXd rhs_exact;
        accumulate(c, exact_rows[c], &q_exact, &rhs_exact);
        const Eigen::VectorXd rhs_data_exact = rhs_exact;
        const double diagonal_max = std::max(1e-30, diagonal[c].maxCoeff());
        const double lambda = options.smoothness * diagonal_max;
        const double model_pull = natural ? fill * kNaturalLightPull * lambda : 0.0;
        if (natural) {
          Eigen::VectorXd prior_rhs = lambda * (regularizer * model_map[c]) + model_pull * model_map[c];
          if (sparsity_penalty.size() > 0)
            prior_rhs += (options.wavelet_sparsity * diagonal_max) * (sparsity_penalty * model_map[c]);
          rhs_exact += prior_rhs;
        }
        // Lower bounds by an active set (semismooth Newton on the censored objective): the bounds the
        // current map misses enter as ordinary rows; re-solve until that set no longer changes.
        std::vector<Eigen::Index> active;
        for (int round = 0; round < (bound_rows[c].empty() ? 1 : kMaxBoundRounds); ++round) {
          std::vector<Eigen::Index> missed;
          if (!bound_rows[c].empty()) {
            const Eigen::VectorXf xf = (split_sun ? with_sun(x) : x).cast<float>();
            for (Eigen::Index r : bound_rows[c])
              if (a[c].row(r).dot(xf) < y[c][r]) missed.push_back(r);
            if (round > 0 && missed == active) break;
            active = missed;
          }
          Eigen::MatrixXd q_mat = q_exact;
          Eigen::VectorXd rhs = rhs_exact;
          Eigen::VectorXd rhs_data = rhs_data_exact;
          if (!active.empty()) {
            Eigen::MatrixXd q_active;
            Eigen::VectorXd rhs_active;
            accumulate(c, active, &q_active, &rhs_active);
            q_mat += q_active;
            rhs += rhs_active;
            rhs_data += rhs_active;
          }
          // The sun's column and diagonal in the data term (H s, sᵀ H s, sᵀ b for the splat vector s).
          Eigen::VectorXd sun_column;
          double sun_diagonal = 0, sun_rhs = 0;
          if (split_sun) {
            sun_column = Eigen::VectorXd::Zero(dim);
            for (const auto& [k, v] : splat) {
              sun_column += v * q_mat.col(k);
              sun_rhs += v * rhs_data[k];
            }
            for (const auto& [k, v] : splat) sun_diagonal += v * sun_column[k];
          }
          q_mat += lambda * regularizer;
          if (model_pull > 0) q_mat.diagonal().array() += model_pull;
          if (sparsity_penalty.size() > 0) q_mat += (options.wavelet_sparsity * diagonal_max) * sparsity_penalty;
          // A vanishing ridge keeps texels no observation sees well-posed (they stay at the smooth fill-in).
          q_mat.diagonal().array() += 1e-9 * diagonal_max;
          if (split_sun) {
            // The sky's QP bordered by the sun's variable (no prior on it).
            Eigen::MatrixXd q_sun(dim + 1, dim + 1);
            q_sun.topLeftCorner(dim, dim) = q_mat;
            q_sun.col(dim).head(dim) = sun_column;
            q_sun.row(dim).head(dim) = sun_column.transpose();
            double splat_norm = 0;
            for (const auto& [k, v] : splat) splat_norm += v * v;
            q_sun(dim, dim) = sun_diagonal + 1e-9 * diagonal_max * splat_norm;
            Eigen::VectorXd rhs_sun(dim + 1), x_sun(dim + 1);
            rhs_sun << rhs, sun_rhs;
            x_sun << x, sun;
            const QpSummary qs = SolveNonNegativeQp(options.qp_solver, q_sun, rhs_sun, &x_sun);
            result.qp_iterations[i] += qs.iterations;
            x = x_sun.head(dim);
            sun = x_sun[dim];
          } else if (haar) {
            const QpSummary qs = SolveNonNegativeQp(options.qp_solver, q_mat, rhs, &x);
            result.qp_iterations[i] += qs.iterations;
          } else {
            int it = 0;
            x = SolveShNonNegative(q_mat, rhs, sh_constraint, &it);
            result.qp_iterations[i] += it;
          }
        }
        if (block == 1) {
          for (int k = 0; k < dim; ++k) lighting->values[i][c][k] = static_cast<float>(x[k]);
        } else {  // piecewise-constant upsampling to the full resolution
          for (int k = 0; k < n_full * n_full; ++k) {
            const int coarse = ((k / n_full) / block) * n + (k % n_full) / block;
            lighting->values[i][c][k] = static_cast<float>(x[coarse]);
          }
        }
        if (split_sun) {  // the sun splatted at the full resolution, where the maps hold it
          for (const auto& [k, v] : SunSplat(sun_dir, n_full)) lighting->values[i][c][k] += static_cast<float>(sun * v);
          lighting->sun_dir_world[i] = sun_dir;
          lighting->sun_irradiance[i][c] = sun;
        }
        const Eigen::VectorXf pred = a[c] * (split_sun ? with_sun(x) : x).cast<float>();
        for (Eigen::Index r = 0; r < rows; ++r) {
          double e = double(y[c][r]) - pred[r];
          if (lower[r * 3 + c] && e < 0) e = 0;  // a lower bound the prediction meets
          residual[r] += e * e;
          sse += alpha[r] * e * e;
          wsum += alpha[r];
        }
      }
      result.photo_rmse[i] = std::sqrt(sse / std::max(1e-30, wsum));
      if (natural && !split_sun && pass + 1 == passes && passes == options.irls_iterations) {
        std::array<std::vector<double>, 3> solved;
        for (int c = 0; c < 3; ++c) {
          solved[c].resize(dim);
          for (int k = 0; k < dim; ++k) {  // the block's value (upsampled piecewise constant)
            const int fine = ((k / n) * block) * n_full + (k % n) * block;
            solved[c][k] = lighting->values[i][c][fine];
          }
        }
        if (clear_sky(FitNaturalLight({solved[0].data(), solved[1].data(), solved[2].data()}, share, n))) ++passes;
      }
      if (pass + 1 < passes) {
        for (double& r : residual) r = std::sqrt(r);
        robust = RobustWeights(residual, options.robust_loss, options.robust_scale);
      }
    }
  });
  transport.EvictAll();  // the vertex rows every photo shared
  lighting->UpdateCoefficients();
  result.seconds = timer.Seconds();
  return result;
}

std::vector<MapResolution> LightingResolution(const TransportStore& transport, const ObservationSet& observations,
                                              const std::vector<std::vector<uint32_t>>& subset,
                                              const ReflectanceState& reflectance, const InverseOptions& options,
                                              const LightingState& lighting) {
  const bool haar = lighting.basis == "haar";
  const int n = lighting.env_resolution;
  const int dim = haar ? n * n : lighting.dim;
  const int num_photos = static_cast<int>(subset.size());
  const Eigen::MatrixXd regularizer = SmoothnessRegularizer(lighting, n);
  // Level (Haar) or band (SH) of every coefficient.
  std::vector<int> level(dim, 0);
  int levels = 0;
  if (haar) {
    levels = 1 + Log2(n);
    for (int k = 1; k < dim; ++k) level[k] = 1 + DecodeHaarIndex(static_cast<uint32_t>(k), n).level;
  } else {
    levels = lighting.sh_order + 1;
    for (int l = 0; l <= lighting.sh_order; ++l)
      for (int m = -l; m <= l; ++m) level[ShIndex(l, m)] = l;
  }
  std::vector<MapResolution> out(num_photos);
  tbb::parallel_for(0, num_photos, [&](int i) {
    MapResolution& res = out[i];
    res.dof_per_level.assign(levels, 0.0);
    res.coefficients_per_level.assign(levels, 0);
    for (int k = 0; k < dim; ++k) ++res.coefficients_per_level[level[k]];
    if (haar) res.data_share.assign(dim, 0.0f);
    const std::vector<uint32_t>& obs = subset[i];
    if (obs.empty()) return;
    const PhotoSystem sys = AssemblePhotoSystem(transport, observations, obs, reflectance, haar, n, n, dim);
    const Eigen::Index rows = static_cast<Eigen::Index>(obs.size());
    std::array<Eigen::VectorXd, 3> x;
    for (int c = 0; c < 3; ++c)
      x[c] = Eigen::Map<const Eigen::VectorXf>(lighting.values[i][c].data(), dim).cast<double>();
    // The robust weights of the final residuals, as the step's last reweighting computes them.
    std::vector<double> residual(rows, 0.0);
    std::array<Eigen::VectorXf, 3> pred;
    for (int c = 0; c < 3; ++c) {
      pred[c] = sys.a[c] * x[c].cast<float>();
      for (Eigen::Index r = 0; r < rows; ++r) {
        double e = double(sys.y[c][r]) - pred[c][r];
        if (sys.lower[r * 3 + c] && e < 0) e = 0;
        residual[r] += e * e;
      }
    }
    for (double& r : residual) r = std::sqrt(r);
    const std::vector<double> robust = options.irls_iterations > 1
                                           ? RobustWeights(residual, options.robust_loss, options.robust_scale)
                                           : std::vector<double>(rows, 1.0);
    Eigen::MatrixXd sparsity_penalty;
    if (haar && options.wavelet_sparsity > 0) {
      sparsity_penalty =
          HaarL1Penalty({lighting.values[i][0].data(), lighting.values[i][1].data(), lighting.values[i][2].data()}, n,
                        options.wavelet_sparsity_floor);
    }
    for (int c = 0; c < 3; ++c) {
      // Rows that measure: the exact ones. A lower bound only says "at least" (the light in a clipped
      // highlight may be far brighter), so it determines nothing, even where the map meets it.
      std::vector<Eigen::Index> active;
      Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(dim);
      for (Eigen::Index r = 0; r < rows; ++r) {
        const double w = sys.alpha[r] * robust[r];
        diagonal += w * sys.a[c].row(r).cast<double>().cwiseAbs2().transpose();  // λ as the step sets it
        if (!sys.lower[r * 3 + c]) active.push_back(r);
      }
      RowMatrix aw(static_cast<Eigen::Index>(active.size()), dim);
      for (size_t k = 0; k < active.size(); ++k)
        aw.row(static_cast<Eigen::Index>(k)) =
            static_cast<float>(std::sqrt(sys.alpha[active[k]] * robust[active[k]])) * sys.a[c].row(active[k]);
      Eigen::MatrixXf hf = Eigen::MatrixXf::Zero(dim, dim);
      hf.selfadjointView<Eigen::Lower>().rankUpdate(aw.transpose());
      const Eigen::MatrixXd h = Eigen::MatrixXd(hf.cast<double>().selfadjointView<Eigen::Lower>());
      // The priors exactly as the lighting step weights them.
      const double diagonal_max = std::max(1e-30, diagonal.maxCoeff());
      Eigen::MatrixXd q = h + (options.smoothness * diagonal_max) * regularizer;
      if (sparsity_penalty.size() > 0) q += (options.wavelet_sparsity * diagonal_max) * sparsity_penalty;
      q.diagonal().array() += 1e-9 * diagonal_max;
      if (haar)
        for (int k = 0; k < dim; ++k) res.data_share[k] += static_cast<float>(h(k, k) / q(k, k) / 3.0);
      Eigen::MatrixXd r = Eigen::LLT<Eigen::MatrixXd>(q).solve(h);  // R = (H + P)⁻¹ H
      if (haar) {
        // R in the Haar basis: W R Wᵀ (W orthonormal), columns then rows.
        std::vector<double> buffer(dim);
        for (int j = 0; j < dim; ++j) {
          HaarForward(r.col(j).data(), n, buffer.data());
          r.col(j) = Eigen::Map<const Eigen::VectorXd>(buffer.data(), dim);
        }
        Eigen::MatrixXd rt = r.transpose();
        for (int j = 0; j < dim; ++j) {
          HaarForward(rt.col(j).data(), n, buffer.data());
          rt.col(j) = Eigen::Map<const Eigen::VectorXd>(buffer.data(), dim);
        }
        r = rt.transpose();
      }
      for (int k = 0; k < dim; ++k) {
        res.dof_per_level[level[k]] += r(k, k) / 3.0;
        res.dof += r(k, k) / 3.0;
      }
    }
  });
  transport.EvictAll();
  return out;
}

double ResolvedDetailDegrees(const MapResolution& m, const std::string& basis) {
  if (basis != "haar") return 0;
  // Entry 1 + l of dof_per_level is wavelet level l: squares of 2^-l of the map's side, whose
  // wavelets tell apart their halves, about sqrt(4π) / 2^(l+1) radians across (the octahedral
  // map's mean texel is sqrt(4π) / n).
  double detail = 0;
  for (size_t e = 1; e < m.dof_per_level.size(); ++e) {
    if (m.coefficients_per_level[e] == 0 || m.dof_per_level[e] < 0.5 * m.coefficients_per_level[e]) break;
    detail = std::sqrt(4 * M_PI) / std::pow(2.0, double(e)) * 180 / M_PI;
  }
  return detail;
}

}  // namespace relight
