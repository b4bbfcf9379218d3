#include "mvs/patch_match.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/timer.h"
#include "mvs/ncc_cost.h"

namespace relight {
namespace {

constexpr float kDepthPerturbation0 = 0.08f;   // relative depth perturbation of the first iteration
constexpr float kNormalPerturbation0 = 0.35f;  // normal perturbation (≈ radians) of the first iteration
constexpr float kMinFacingCos = 0.1f;          // normals face the camera by at least this cosine (≤ 84°)
constexpr float kPi = 3.14159265358979f;
constexpr float kSamePlaneDepth = 1e-4f;       // candidates this close (relative depth) ...
constexpr float kSamePlaneCos = 0.99996f;      // ... and normal (0.5°) to the best plane are not evaluated

// ---- deterministic per-pixel random numbers (independent of thread scheduling)
uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

class Rng {
 public:
  Rng(uint64_t a, uint64_t b, uint64_t c, uint64_t d)
      : state_(SplitMix64(SplitMix64(SplitMix64(SplitMix64(a) ^ b) ^ c) ^ d) | 1) {}
  uint64_t Next() {  // xorshift64*
    state_ ^= state_ >> 12;
    state_ ^= state_ << 25;
    state_ ^= state_ >> 27;
    return state_ * 2685821657736338717ULL;
  }
  float Uniform() { return float(Next() >> 40) * (1.0f / 16777216.0f); }  // [0, 1)
  float Symmetric() { return 2.0f * Uniform() - 1.0f; }                   // [-1, 1)

 private:
  uint64_t state_;
};

// ---- adaptive checkerboard regions (ACMH): offsets of the other colour (odd |dx| + |dy|)
struct Offset {
  int dx, dy;
};
using Region = std::vector<Offset>;

std::array<Region, 8> MakeRegions() {
  const Region near_up = {{0, -1}, {-1, -2}, {1, -2}, {0, -3}, {-2, -3}, {2, -3}};
  Region far_up;
  for (int d = 5; d <= 25; d += 2) far_up.push_back({0, -d});
  std::array<Region, 8> regions;
  const auto rotate = [](const Region& r, int k) {
    Region out;
    for (Offset o : r) {
      for (int i = 0; i < k; ++i) o = {-o.dy, o.dx};  // 90° rotation keeps |dx| + |dy|
      out.push_back(o);
    }
    return out;
  };
  for (int k = 0; k < 4; ++k) {
    regions[k] = rotate(near_up, k);
    regions[4 + k] = rotate(far_up, k);
  }
  return regions;
}

// Geometry of one source view relative to the reference camera.
struct SourceGeometry {
  const Image* gray = nullptr;     // for the plain cost
  SamplingImage sampling;          // for the vectorised cost
  int width = 0, height = 0;
  Eigen::Matrix3f A;           // K_s R K_r⁻¹
  Eigen::Vector3f b;           // K_s t
  Eigen::Matrix3f R;           // source_from_ref rotation
  Eigen::Vector3f t;           // source_from_ref translation
  Eigen::Matrix3f K, K_inv;    // source intrinsics
  Eigen::Vector3f center_ref;  // source camera centre in the reference camera frame
  const DepthNormalMap* map = nullptr;
};

// Per-hypothesis costs against every source view, aggregated.
class Matcher {
 public:
  Matcher(const MvsOptions& options, const PatchMatchProblem& problem, bool geometric, CostKernel kernel)
      : options_(options), problem_(problem), geometric_(geometric), kernel_(kernel) {
    const StereoView& ref = *problem.ref;
    RELIGHT_CHECK(!ref.gray.empty() && ref.gray.width == ref.width && ref.gray.height == ref.height)
        << "reference image of " << ref.name << " not loaded";
    RELIGHT_CHECK(ref.width >= 2 && ref.height >= 2) << ref.name;
    fx_ = float(ref.K(0, 0));
    fy_ = float(ref.K(1, 1));
    cx_ = float(ref.K(0, 2));
    cy_ = float(ref.K(1, 2));
    K_ref_ = ref.K.cast<float>();
    const Eigen::Matrix3d K_ref_inv = ref.K.inverse();
    for (size_t s = 0; s < problem.sources.size(); ++s) {
      const StereoView& src = *problem.sources[s];
      RELIGHT_CHECK(!src.gray.empty() && src.gray.width == src.width && src.gray.height == src.height)
          << "source image " << src.name << " not loaded";
      RELIGHT_CHECK(src.width >= 2 && src.height >= 2) << src.name;
      SourceGeometry g;
      g.gray = &src.gray;
      if (kernel == CostKernel::kVectorized) g.sampling = MakeSamplingImage(src.gray);
      g.width = src.width;
      g.height = src.height;
      const Eigen::Matrix3d R = src.R_cam_from_world * ref.R_cam_from_world.transpose();
      const Eigen::Vector3d t = src.t_cam_from_world - R * ref.t_cam_from_world;
      g.A = (src.K * R * K_ref_inv).cast<float>();
      g.b = (src.K * t).cast<float>();
      g.R = R.cast<float>();
      g.t = t.cast<float>();
      g.K = src.K.cast<float>();
      g.K_inv = src.K.inverse().cast<float>();
      g.center_ref = (-R.transpose() * t).cast<float>();
      if (geometric) {
        RELIGHT_CHECK_EQ(problem.source_maps.size(), problem.sources.size());
        g.map = problem.source_maps[s];
        if (g.map != nullptr) {
          RELIGHT_CHECK(g.map->width == src.width && g.map->height == src.height) << src.name;
        }
      }
      sources_.push_back(g);
    }
    pattern_ = MakeWindowPattern(options.window_radius, options.window_step, float(options.sigma_spatial));
    depth_min_ = float(problem.depth_min);
    depth_max_ = float(problem.depth_max);
    num_best_ = std::min<int>(options.num_best_views, static_cast<int>(sources_.size()));
  }

  int num_sources() const { return static_cast<int>(sources_.size()); }
  const WindowPattern& pattern() const { return pattern_; }
  float depth_min() const { return depth_min_; }
  float depth_max() const { return depth_max_; }

  // Ray through the centre of pixel (col, row), z = 1.
  Eigen::Vector3f Ray(int col, int row) const {
    return Eigen::Vector3f((col + 0.5f - cx_) / fx_, (row + 0.5f - cy_) / fy_, 1.0f);
  }

  void PrepareWindow(int col, int row, RefWindow* window) const {
    PrepareRefWindow(problem_.ref->gray, col, row, pattern_, float(options_.sigma_color), window);
  }

  // Photometric (+ geometric) cost of the plane (depth, n) at pixel (col, row) in every source view.
  // Returns false when the plane does not face the camera.
  bool ViewCosts(const RefWindow& window, int col, int row, float depth, const Eigen::Vector3f& n,
                 float* photometric, float* reprojection_px) const {
    const Eigen::Vector3f X = depth * Ray(col, row);
    const float q = n.dot(X);
    if (!(q < 0.0f)) return false;
    // m = K_r⁻ᵀ n / q; H = A + b mᵀ.
    const Eigen::Vector3f m =
        Eigen::Vector3f(n.x() / fx_, n.y() / fy_, n.z() - n.x() * cx_ / fx_ - n.y() * cy_ / fy_) / q;
    for (size_t s = 0; s < sources_.size(); ++s) {
      const SourceGeometry& g = sources_[s];
      const Homography H = g.A + g.b * m.transpose();
      if (kernel_ == CostKernel::kVectorized) {
        photometric[s] = NccCost(window, pattern_, H, g.sampling);
      } else {
        photometric[s] = NccCostPlain(problem_.ref->gray, col, row, options_.window_radius, options_.window_step,
                                      float(options_.sigma_color), float(options_.sigma_spatial), H, *g.gray);
      }
      if (reprojection_px != nullptr) reprojection_px[s] = ReprojectionError(g, X, col, row);
    }
    return true;
  }

  // Aggregated cost: mean of the k best per-view costs (photometric + λ · truncated reprojection error).
  float Evaluate(const RefWindow& window, int col, int row, float depth, const Eigen::Vector3f& n,
                 float* scratch) const {
    const int S = num_sources();
    float* photometric = scratch;
    float* reprojection = geometric_ ? scratch + S : nullptr;
    if (!ViewCosts(window, col, row, depth, n, photometric, reprojection)) return kMaxCost();
    if (geometric_) {
      const float lambda = float(options_.geom_regularizer);
      const float max_px = float(options_.geom_max_cost_px);
      for (int s = 0; s < S; ++s) photometric[s] += lambda * std::min(reprojection[s], max_px);
    }
    if (num_best_ < S) std::nth_element(photometric, photometric + num_best_ - 1, photometric + S);
    float sum = 0.0f;
    for (int s = 0; s < num_best_; ++s) sum += photometric[s];
    return sum / float(num_best_);
  }

  // Largest possible aggregated cost.
  float kMaxCost() const {
    return kMaxNccCost + (geometric_ ? float(options_.geom_regularizer * options_.geom_max_cost_px) : 0.0f);
  }

  // Forward-backward reprojection error (pixels) of reference point X_ref through source view `g`'s depth map.
  float ReprojectionError(const SourceGeometry& g, const Eigen::Vector3f& X_ref, int col, int row) const {
    const float kFail = std::numeric_limits<float>::infinity();
    if (g.map == nullptr) return kFail;
    const Eigen::Vector3f Xs = g.R * X_ref + g.t;
    if (!(Xs.z() > 0.0f)) return kFail;
    const Eigen::Vector3f ps = g.K * (Xs / Xs.z());
    if (!(ps.x() >= 0.0f && ps.y() >= 0.0f && ps.x() < float(g.width) && ps.y() < float(g.height))) return kFail;
    const int ix = static_cast<int>(ps.x()), iy = static_cast<int>(ps.y());
    const size_t i = g.map->index(ix, iy);
    const float d_src = g.map->depth[i];
    if (!(d_src > 0.0f)) return kFail;
    // The source pixel's plane, intersected with the exact ray through ps.
    const Eigen::Vector3f& n_src = g.map->normal_cam[i];
    const Eigen::Vector3f ray = g.K_inv * Eigen::Vector3f(ps.x(), ps.y(), 1.0f);
    const Eigen::Vector3f X_pix = d_src * (g.K_inv * Eigen::Vector3f(ix + 0.5f, iy + 0.5f, 1.0f));
    float d = d_src;
    const float denom = n_src.dot(ray);
    if (denom < -1e-3f) {
      const float d_plane = n_src.dot(X_pix) / denom;
      if (d_plane > 0.5f * d_src && d_plane < 2.0f * d_src) d = d_plane;
    }
    const Eigen::Vector3f X_back = g.R.transpose() * (d * ray - g.t);
    if (!(X_back.z() > 0.0f)) return kFail;
    const Eigen::Vector3f pr = K_ref_ * (X_back / X_back.z());
    return std::hypot(pr.x() - (col + 0.5f), pr.y() - (row + 0.5f));
  }

  // Triangulation angle (radians) at reference point X_ref between the reference and source `s` rays.
  float TriangulationAngle(int s, const Eigen::Vector3f& X_ref) const {
    const Eigen::Vector3f a = -X_ref;
    const Eigen::Vector3f b = sources_[s].center_ref - X_ref;
    const float c = a.dot(b) / std::max(1e-20f, a.norm() * b.norm());
    return std::acos(std::clamp(c, -1.0f, 1.0f));
  }

 private:
  const MvsOptions& options_;
  const PatchMatchProblem& problem_;
  bool geometric_;
  CostKernel kernel_;
  float fx_, fy_, cx_, cy_;
  Eigen::Matrix3f K_ref_;
  std::vector<SourceGeometry> sources_;
  WindowPattern pattern_;
  float depth_min_, depth_max_;
  int num_best_;
};

// Plane hypothesis state of the whole image.
struct State {
  int width, height;
  std::vector<float> depth;
  std::vector<Eigen::Vector3f> normal;
  std::vector<float> cost;
};

Eigen::Vector3f RandomNormal(Rng* rng, const Eigen::Vector3f& ray_unit) {
  for (int attempt = 0; attempt < 8; ++attempt) {
    const float z = rng->Symmetric();
    const float phi = 2.0f * kPi * rng->Uniform();
    const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
    Eigen::Vector3f n(s * std::cos(phi), s * std::sin(phi), z);
    if (n.dot(ray_unit) > 0.0f) n = -n;
    if (-n.dot(ray_unit) >= kMinFacingCos) return n;
  }
  return -ray_unit;
}

Eigen::Vector3f PerturbNormal(Rng* rng, const Eigen::Vector3f& n, const Eigen::Vector3f& ray_unit, float sigma) {
  for (int attempt = 0; attempt < 4; ++attempt) {
    Eigen::Vector3f p = n + sigma * Eigen::Vector3f(rng->Symmetric(), rng->Symmetric(), rng->Symmetric());
    const float len = p.norm();
    if (!(len > 1e-6f)) continue;
    p /= len;
    if (-p.dot(ray_unit) >= kMinFacingCos) return p;
  }
  return n;
}

float RandomDepth(Rng* rng, float depth_min, float depth_max) {
  // Uniform in inverse depth (uniform in disparity, Gipuma).
  const float inv = 1.0f / depth_max + rng->Uniform() * (1.0f / depth_min - 1.0f / depth_max);
  return 1.0f / inv;
}

class Sweeper {
 public:
  Sweeper(const MvsOptions& options, const PatchMatchProblem& problem, const Matcher& matcher, State* state)
      : options_(options), problem_(problem), matcher_(matcher), state_(*state), regions_(MakeRegions()) {}

  // Random or given initial planes and their costs.
  void Initialize(const DepthNormalMap* init) {
    ForRows([&](int row, RefWindow* window, std::vector<float>* scratch) {
      for (int col = 0; col < state_.width; ++col) {
        const size_t i = size_t(row) * state_.width + col;
        const Eigen::Vector3f ray = matcher_.Ray(col, row);
        const Eigen::Vector3f ray_unit = ray.normalized();
        Rng rng(options_.seed, problem_.image_seed, 0xA5A5, i);
        bool given = false;
        if (init != nullptr && init->depth[i] > 0.0f) {
          const Eigen::Vector3f& n = init->normal_cam[i];
          if (-n.dot(ray_unit) >= 0.5f * kMinFacingCos) {
            state_.depth[i] = std::clamp(init->depth[i], matcher_.depth_min(), matcher_.depth_max());
            state_.normal[i] = n;
            given = true;
          }
        }
        if (!given) {
          state_.depth[i] = RandomDepth(&rng, matcher_.depth_min(), matcher_.depth_max());
          state_.normal[i] = RandomNormal(&rng, ray_unit);
        }
        matcher_.PrepareWindow(col, row, window);
        state_.cost[i] = window->textured()
                             ? matcher_.Evaluate(*window, col, row, state_.depth[i], state_.normal[i], scratch->data())
                             : matcher_.kMaxCost();
      }
    });
  }

  // One iteration: all black pixels, then all red ones.
  void Iterate(int iteration) {
    const float depth_sigma = kDepthPerturbation0 * std::pow(0.5f, float(iteration));
    const float normal_sigma = kNormalPerturbation0 * std::pow(0.5f, float(iteration));
    for (int color = 0; color < 2; ++color) {
      ForRows([&](int row, RefWindow* window, std::vector<float>* scratch) {
        for (int col = (row + color) % 2; col < state_.width; col += 2) {
          UpdatePixel(col, row, iteration, depth_sigma, normal_sigma, window, scratch->data());
        }
      });
    }
  }

 private:
  template <typename Fn>
  void ForRows(const Fn& fn) {
    tbb::parallel_for(tbb::blocked_range<int>(0, state_.height, 2), [&](const tbb::blocked_range<int>& range) {
      RefWindow window;
      std::vector<float> scratch(2 * std::max(1, matcher_.num_sources()));
      for (int row = range.begin(); row < range.end(); ++row) fn(row, &window, &scratch);
    });
  }

  void UpdatePixel(int col, int row, int iteration, float depth_sigma, float normal_sigma, RefWindow* window,
                   float* scratch) {
    const int W = state_.width, H = state_.height;
    const size_t i = size_t(row) * W + col;
    matcher_.PrepareWindow(col, row, window);
    if (!window->textured()) return;
    const Eigen::Vector3f ray = matcher_.Ray(col, row);
    const Eigen::Vector3f ray_unit = ray.normalized();
    float best_depth = state_.depth[i];
    Eigen::Vector3f best_normal = state_.normal[i];
    float best_cost = state_.cost[i];
    const auto consider = [&](float depth, const Eigen::Vector3f& n) {
      if (!(depth >= matcher_.depth_min() && depth <= matcher_.depth_max())) return;
      if (-n.dot(ray_unit) < 0.5f * kMinFacingCos) return;
      // A plane (nearly) equal to the best one cannot improve it: skip its cost (most candidates once converged).
      if (std::abs(depth - best_depth) <= kSamePlaneDepth * best_depth && n.dot(best_normal) >= kSamePlaneCos) return;
      const float c = matcher_.Evaluate(*window, col, row, depth, n, scratch);
      if (c < best_cost) {
        best_cost = c;
        best_depth = depth;
        best_normal = n;
      }
    };

    // Propagation: the lowest-cost neighbour of each region, its plane intersected with this pixel's ray.
    size_t chosen[8];
    int num_chosen = 0;
    for (const Region& region : regions_) {
      float region_cost = std::numeric_limits<float>::infinity();
      size_t region_best = 0;
      bool found = false;
      for (const Offset& o : region) {
        const int x = col + o.dx, y = row + o.dy;
        if (x < 0 || y < 0 || x >= W || y >= H) continue;
        const size_t j = size_t(y) * W + x;
        if (state_.cost[j] < region_cost) {
          region_cost = state_.cost[j];
          region_best = j;
          found = true;
        }
      }
      if (!found || std::find(chosen, chosen + num_chosen, region_best) != chosen + num_chosen) continue;
      chosen[num_chosen++] = region_best;
      const int x = static_cast<int>(region_best % W), y = static_cast<int>(region_best / W);
      const Eigen::Vector3f& n = state_.normal[region_best];
      const float denom = n.dot(ray);
      if (!(denom < 0.0f)) continue;
      const float depth = n.dot(state_.depth[region_best] * matcher_.Ray(x, y)) / denom;
      consider(depth, n);
    }

    // Refinement: random and perturbed depths and normals around the best plane.
    Rng rng(options_.seed, problem_.image_seed, 0x5EED0000ULL + iteration, i);
    const float d0 = best_depth;
    const Eigen::Vector3f n0 = best_normal;
    const float d_random = RandomDepth(&rng, matcher_.depth_min(), matcher_.depth_max());
    const Eigen::Vector3f n_random = RandomNormal(&rng, ray_unit);
    const float d_perturbed =
        std::clamp(d0 * (1.0f + depth_sigma * rng.Symmetric()), matcher_.depth_min(), matcher_.depth_max());
    const Eigen::Vector3f n_perturbed = PerturbNormal(&rng, n0, ray_unit, normal_sigma);
    consider(d_random, n_random);
    consider(d_perturbed, n_perturbed);
    consider(d0, n_perturbed);
    consider(d_perturbed, n0);
    consider(d0, n_random);

    state_.depth[i] = best_depth;
    state_.normal[i] = best_normal;
    state_.cost[i] = best_cost;
  }

  const MvsOptions& options_;
  const PatchMatchProblem& problem_;
  const Matcher& matcher_;
  State& state_;
  std::array<Region, 8> regions_;
};

}  // namespace

DepthNormalMap RunPatchMatch(const MvsOptions& options, const PatchMatchProblem& problem, bool geometric,
                             int iterations, const DepthNormalMap* init, int iteration_offset, CostKernel kernel,
                             PatchMatchStats* stats) {
  Timer timer;
  RELIGHT_CHECK(problem.ref != nullptr && !problem.sources.empty()) << "no reference or source views";
  RELIGHT_CHECK(problem.depth_min > 0 && problem.depth_max > problem.depth_min)
      << problem.depth_min << " " << problem.depth_max;
  const Matcher matcher(options, problem, geometric, kernel);
  const StereoView& ref = *problem.ref;
  if (init != nullptr) {
    RELIGHT_CHECK(init->width == ref.width && init->height == ref.height) << ref.name;
  }
  State state{ref.width, ref.height, std::vector<float>(size_t(ref.width) * ref.height),
              std::vector<Eigen::Vector3f>(size_t(ref.width) * ref.height),
              std::vector<float>(size_t(ref.width) * ref.height)};
  Sweeper sweeper(options, problem, matcher, &state);
  sweeper.Initialize(init);
  for (int it = 0; it < iterations; ++it) sweeper.Iterate(iteration_offset + it);

  DepthNormalMap map(ref.width, ref.height);
  map.depth = std::move(state.depth);
  map.normal_cam = std::move(state.normal);
  map.cost = std::move(state.cost);
  if (stats != nullptr) {
    double sum = 0;
    size_t textured = 0;
    const float max_cost = matcher.kMaxCost();
    for (float c : map.cost) {
      if (c < max_cost) {
        sum += c;
        ++textured;
      }
    }
    stats->iterations = iterations;
    stats->seconds = timer.Seconds();
    stats->mean_cost = textured > 0 ? sum / textured : 0.0;
    stats->textured_fraction = double(textured) / map.cost.size();
  }
  return map;
}

FilterStats FilterDepthMap(const MvsOptions& options, const PatchMatchProblem& problem, bool geometric,
                           DepthNormalMap* map) {
  const Matcher matcher(options, problem, geometric, CostKernel::kVectorized);
  const int W = map->width, H = map->height;
  RELIGHT_CHECK(W == problem.ref->width && H == problem.ref->height) << problem.ref->name;
  FilterStats stats;
  stats.valid_before = map->ValidFraction();
  const float max_photometric = float(1.0 - options.filter_min_ncc);
  const float min_angle = float(options.filter_min_triangulation_angle_deg * M_PI / 180.0);
  const float max_error = float(options.filter_geom_max_error_px);
  const int S = matcher.num_sources();
  std::vector<uint8_t> keep(size_t(W) * H, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 2), [&](const tbb::blocked_range<int>& range) {
    RefWindow window;
    std::vector<float> photometric(S), reprojection(S);
    for (int row = range.begin(); row < range.end(); ++row) {
      for (int col = 0; col < W; ++col) {
        const size_t i = map->index(col, row);
        const float depth = map->depth[i];
        if (!(depth > 0.0f)) continue;
        matcher.PrepareWindow(col, row, &window);
        if (!window.textured()) continue;
        if (!matcher.ViewCosts(window, col, row, depth, map->normal_cam[i], photometric.data(),
                               geometric ? reprojection.data() : nullptr)) {
          continue;
        }
        const Eigen::Vector3f X = depth * matcher.Ray(col, row);
        int support = 0;
        for (int s = 0; s < S; ++s) {
          if (photometric[s] > max_photometric) continue;
          if (geometric && !(reprojection[s] <= max_error)) continue;
          if (matcher.TriangulationAngle(s, X) < min_angle) continue;
          ++support;
        }
        keep[i] = support >= options.filter_min_num_consistent;
      }
    }
  });
  for (size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i] && map->depth[i] > 0.0f) {
      ++stats.removed_support;
      map->depth[i] = 0.0f;
      map->normal_cam[i].setZero();
    }
  }

  // Small connected segments (4-neighbours whose depths differ by < 2%) are speckles.
  // Hand-written: cv::filterSpeckles takes 8/16-bit disparities with an absolute step, not float depths.
  if (options.filter_min_segment_px > 0) {
    std::vector<int> label(size_t(W) * H, -1);
    std::vector<size_t> stack, members;
    for (size_t seed = 0; seed < label.size(); ++seed) {
      if (label[seed] >= 0 || !(map->depth[seed] > 0.0f)) continue;
      members.clear();
      stack.assign(1, seed);
      label[seed] = 1;
      while (!stack.empty()) {
        const size_t p = stack.back();
        stack.pop_back();
        members.push_back(p);
        const int x = static_cast<int>(p % W), y = static_cast<int>(p / W);
        const float d = map->depth[p];
        const int nx[4] = {x - 1, x + 1, x, x};
        const int ny[4] = {y, y, y - 1, y + 1};
        for (int k = 0; k < 4; ++k) {
          if (nx[k] < 0 || ny[k] < 0 || nx[k] >= W || ny[k] >= H) continue;
          const size_t q = size_t(ny[k]) * W + nx[k];
          const float dq = map->depth[q];
          if (label[q] >= 0 || !(dq > 0.0f) || std::abs(dq - d) > 0.02f * std::max(dq, d)) continue;
          label[q] = 1;
          stack.push_back(q);
        }
      }
      if (static_cast<int>(members.size()) < options.filter_min_segment_px) {
        for (size_t p : members) {
          map->depth[p] = 0.0f;
          map->normal_cam[p].setZero();
        }
        stats.removed_segments += members.size();
      }
    }
  }
  if (!map->cost.empty()) {
    for (size_t i = 0; i < map->cost.size(); ++i) {
      if (!(map->depth[i] > 0.0f)) map->cost[i] = matcher.kMaxCost();
    }
  }
  stats.valid_after = map->ValidFraction();
  return stats;
}

}  // namespace relight
