#include "render/integrator.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.h"
#include "sphere/frame.h"

namespace relight {
namespace {

// Largest sample count of one strategy per shading point (stack buffers for stratification).
constexpr int kMaxStrataSamples = 4096;

// Stratified points in [0,1)^2: a jittered grid when n is a square, else a Latin hypercube.
class Stratified2D {
 public:
  Stratified2D(int n, Pcg32* rng) : n_(n), rng_(rng) {
    side_ = static_cast<int>(std::lround(std::sqrt(double(n))));
    grid_ = side_ * side_ == n;
    if (!grid_) {
      for (int i = 0; i < n; ++i) perm_[i] = static_cast<uint16_t>(i);
      for (int i = n - 1; i > 0; --i) std::swap(perm_[i], perm_[rng->UniformInt(uint32_t(i + 1))]);
    }
  }
  Eigen::Vector2d operator()(int k) {
    if (grid_) return {(k % side_ + rng_->Uniform()) / side_, (k / side_ + rng_->Uniform()) / side_};
    return {(k + rng_->Uniform()) / n_, (perm_[k] + rng_->Uniform()) / n_};
  }

 private:
  int n_;
  Pcg32* rng_;
  int side_ = 1;
  bool grid_ = true;
  std::array<uint16_t, kMaxStrataSamples> perm_;
};

double PowerHeuristic(double n_f, double pdf_f, double n_g, double pdf_g) {
  const double f = n_f * pdf_f, g = n_g * pdf_g;
  if (f <= 0) return 0;
  if (!std::isfinite(f)) return 1;
  return f * f / (f * f + g * g);
}

// Probability of choosing each lobe for BRDF sampling: half by the lobe's
// (approximate) reflected energy, half uniform over non-zero lobes, so every
// lobe that contributes is sampled.
int LobeProbabilities(const Scene& scene, const SurfacePoint& p, double cos_o, std::array<double, kMaxLobes>* prob) {
  const auto& basis = scene.surface(p.surface).reflectance.basis;
  double total = 0;
  int nonzero = 0;
  std::array<double, kMaxLobes> energy{};
  for (int b = 0; b < p.num_lobes; ++b) {
    const double k = Luminance(p.lobe_rgb[b]);
    if (!(k > 0)) continue;
    double albedo = 1.0;
    if (basis[b].model == BrdfModel::kCookTorrance || basis[b].model == BrdfModel::kGgx) {
      albedo = brdf_internal::Schlick(basis[b].f0, cos_o);
    }
    energy[b] = k * albedo;
    total += energy[b];
    ++nonzero;
  }
  prob->fill(0.0);
  if (nonzero == 0) return 0;
  for (int b = 0; b < p.num_lobes; ++b) {
    if (!(Luminance(p.lobe_rgb[b]) > 0)) continue;
    (*prob)[b] = 0.5 * (total > 0 ? energy[b] / total : 1.0 / nonzero) + 0.5 / nonzero;
  }
  return nonzero;
}

Eigen::Vector3d Shade(const Scene& scene, const Lighting& lighting, const SurfacePoint& p, const Eigen::Vector3d& wo,
                      const RenderOptions& options, int num_light, int num_brdf, bool bounce, Pcg32* rng) {
  const double eps = options.ray_offset_relative * scene.diagonal();
  // Two-sided surfaces: orient the normals towards the viewer.
  Eigen::Vector3d ng = p.normal_geometric_world, ns = p.normal_shading_world;
  if (ng.dot(wo) < 0) {
    ng = -ng;
    ns = -ns;
  }
  // Keep the viewer above the shading hemisphere (interpolated normals can tip away near silhouettes).
  constexpr double kMinCos = 0.01;
  const double c = ns.dot(wo);
  if (c < kMinCos) ns = (ns + (kMinCos - c) * wo).normalized();
  const LocalFrame<double> frame = FrameFromNormal<double>(ns);
  const Eigen::Vector3d wo_local = frame.ToLocal(wo);
  const Eigen::Vector3f origin = (p.position_world + eps * ng).cast<float>();
  const auto& basis = scene.surface(p.surface).reflectance.basis;

  auto brdf = [&](const Eigen::Vector3d& wi_local) {
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    for (int b = 0; b < p.num_lobes; ++b) {
      if (p.lobe_rgb[b].isZero()) continue;
      f += p.lobe_rgb[b] * basis[b].Eval<double>(wi_local, wo_local);
    }
    return f;
  };
  std::array<double, kMaxLobes> lobe_prob;
  const int nonzero_lobes = LobeProbabilities(scene, p, wo_local.z(), &lobe_prob);
  if (nonzero_lobes == 0) return Eigen::Vector3d::Zero();
  auto brdf_pdf = [&](const Eigen::Vector3d& wi_local) {
    double pdf = 0;
    for (int b = 0; b < p.num_lobes; ++b)
      if (lobe_prob[b] > 0) pdf += lobe_prob[b] * basis[b].Pdf(wo_local, wi_local);
    return pdf;
  };
  auto occluded = [&](const Eigen::Vector3d& dir, float t_far) {
    Ray ray;
    ray.origin = origin;
    ray.dir = dir.cast<float>();
    ray.t_near = static_cast<float>(eps);
    ray.t_far = t_far;
    return scene.caster().Occluded(ray);
  };

  Eigen::Vector3d radiance = Eigen::Vector3d::Zero();
  // Delta lights.
  for (const DirectionalLight& light : lighting.directional) {
    const Eigen::Vector3d wi = light.dir_world.normalized();
    const Eigen::Vector3d wi_local = frame.ToLocal(wi);
    if (wi_local.z() <= 0 || wi.dot(ng) <= 0) continue;
    const Eigen::Vector3d f = brdf(wi_local);
    if (f.isZero()) continue;
    if (occluded(wi, std::numeric_limits<float>::infinity())) continue;
    radiance += f.cwiseProduct(light.irradiance_rgb) * wi_local.z();
  }
  for (const PointLight& light : lighting.points) {
    Eigen::Vector3d to_light = light.position_world - p.position_world;
    const double dist = to_light.norm();
    if (!(dist > eps)) continue;
    const Eigen::Vector3d wi = to_light / dist;
    const Eigen::Vector3d wi_local = frame.ToLocal(wi);
    if (wi_local.z() <= 0 || wi.dot(ng) <= 0) continue;
    const Eigen::Vector3d f = brdf(wi_local);
    if (f.isZero()) continue;
    if (occluded(wi, static_cast<float>(dist - 2 * eps))) continue;
    radiance += f.cwiseProduct(light.intensity_rgb) * (wi_local.z() / (dist * dist));
  }

  const EnvMap* env = lighting.env.get();
  const int n_light = env != nullptr ? num_light : 0;
  const int n_brdf = num_brdf;
  // Environment importance sampling.
  if (n_light > 0) {
    Stratified2D strata(n_light, rng);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k = 0; k < n_light; ++k) {
      const Eigen::Vector2d u = strata(k);
      double pdf_light = 0;
      const Eigen::Vector3d wi = env->Sample(u.x(), u.y(), &pdf_light);
      if (!(pdf_light > 0)) continue;
      const Eigen::Vector3d wi_local = frame.ToLocal(wi);
      if (wi_local.z() <= 0 || wi.dot(ng) <= 0) continue;
      const Eigen::Vector3d f = brdf(wi_local);
      if (f.isZero()) continue;
      if (occluded(wi, std::numeric_limits<float>::infinity())) continue;
      const double weight = PowerHeuristic(n_light, pdf_light, n_brdf, brdf_pdf(wi_local));
      sum += (weight * wi_local.z() / pdf_light) * f.cwiseProduct(env->Lookup(wi));
    }
    radiance += sum / n_light;
  }
  // BRDF importance sampling (and the bounce).
  if (n_brdf > 0) {
    Stratified2D strata(n_brdf, rng);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k = 0; k < n_brdf; ++k) {
      Eigen::Vector2d u = strata(k);
      // Choose a lobe with u.x and reuse the remainder of u.x inside it (keeps the stratification).
      int lobe = -1;
      double start = 0, accumulated = 0;
      for (int b = 0; b < p.num_lobes; ++b) {
        if (lobe_prob[b] <= 0) continue;
        lobe = b;
        start = accumulated;
        accumulated += lobe_prob[b];
        if (u.x() < accumulated) break;
      }
      u.x() = std::clamp((u.x() - start) / lobe_prob[lobe], 0.0, std::nextafter(1.0, 0.0));
      double pdf_lobe = 0;
      const Eigen::Vector3d wi_local = basis[lobe].Sample(wo_local, u.x(), u.y(), &pdf_lobe).normalized();
      if (wi_local.z() <= 0 || !(pdf_lobe > 0)) continue;
      const Eigen::Vector3d wi = frame.ToWorld(wi_local);
      if (wi.dot(ng) <= 0) continue;
      const Eigen::Vector3d f = brdf(wi_local);
      if (f.isZero()) continue;
      const double pdf = brdf_pdf(wi_local);
      if (!(pdf > 0)) continue;
      Ray ray;
      ray.origin = origin;
      ray.dir = wi.cast<float>();
      ray.t_near = static_cast<float>(eps);
      if (bounce) {
        const RayHit hit = scene.caster().Intersect(ray);
        if (hit.hit) {
          if (!options.bounce_from_occluders && scene.surface(int(hit.geom_id)).role == SurfaceRole::kOccluder)
            continue;  // blocked, and sends nothing back
          const SurfacePoint q = scene.PointFromHit(hit);
          const Eigen::Vector3d incoming = Shade(scene, lighting, q, -wi, options, options.bounce_light_samples,
                                                 options.bounce_brdf_samples, false, rng);
          sum += (wi_local.z() / pdf) * f.cwiseProduct(incoming);
          continue;
        }
      } else if (env == nullptr || scene.caster().Occluded(ray)) {
        continue;
      }
      if (env == nullptr) continue;
      const double weight = PowerHeuristic(n_brdf, pdf, n_light, n_light > 0 ? env->Pdf(wi) : 0.0);
      sum += (weight * wi_local.z() / pdf) * f.cwiseProduct(env->Lookup(wi));
    }
    radiance += sum / n_brdf;
  }
  return radiance;
}

}  // namespace

void RenderOptions::Check() const {
  if (pixel_samples_per_axis < 1 || pixel_samples_per_axis > 64)
    RELIGHT_USER_ERROR() << "pixel_samples_per_axis = " << pixel_samples_per_axis << " must lie in [1, 64]";
  if (light_samples < 0 || light_samples > kMaxStrataSamples)
    RELIGHT_USER_ERROR() << "light_samples = " << light_samples << " must lie in [0, " << kMaxStrataSamples << "]";
  if (brdf_samples < 0 || brdf_samples > kMaxStrataSamples)
    RELIGHT_USER_ERROR() << "brdf_samples = " << brdf_samples << " must lie in [0, " << kMaxStrataSamples << "]";
  if (light_samples + brdf_samples < 1)
    RELIGHT_USER_ERROR() << "light_samples + brdf_samples must be at least 1 (no environment light otherwise)";
  if (bounce_light_samples < 0 || bounce_light_samples > kMaxStrataSamples || bounce_brdf_samples < 0 ||
      bounce_brdf_samples > kMaxStrataSamples)
    RELIGHT_USER_ERROR() << "bounce_light_samples and bounce_brdf_samples must lie in [0, " << kMaxStrataSamples << "]";
  if (interreflection && brdf_samples < 1)
    RELIGHT_USER_ERROR() << "interreflection needs brdf_samples >= 1 (bounces follow BRDF samples)";
  if (tile_size < 1) RELIGHT_USER_ERROR() << "tile_size = " << tile_size << " must be at least 1";
  if (!(ray_offset_relative > 0 && ray_offset_relative < 0.01))
    RELIGHT_USER_ERROR() << "ray_offset_relative = " << ray_offset_relative << " must lie in (0, 0.01)";
}

Eigen::Vector3d OutgoingRadiance(const Scene& scene, const Lighting& lighting, const SurfacePoint& point,
                                 const Eigen::Vector3d& dir_out_world, const RenderOptions& options, Pcg32* rng) {
  RELIGHT_CHECK(point.surface >= 0 && point.surface < scene.num_surfaces());
  return Shade(scene, lighting, point, dir_out_world.normalized(), options, options.light_samples, options.brdf_samples,
               options.interreflection, rng);
}

Eigen::Vector3d EvalPointBrdf(const Scene& scene, const SurfacePoint& point, const Eigen::Vector3d& wi_local,
                              const Eigen::Vector3d& wo_local) {
  const auto& basis = scene.surface(point.surface).reflectance.basis;
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  for (int b = 0; b < point.num_lobes; ++b) f += point.lobe_rgb[b] * basis[b].Eval<double>(wi_local, wo_local);
  return f;
}

}  // namespace relight
