#include "relight/transport_render.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "core/error.h"
#include "core/log.h"
#include "core/timer.h"
#include "render/sun_light.h"
#include "solver/transport.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"
#include "wavelet/haar.h"

namespace relight {

// Scratch of the vectorised loops. Eigen treats a buffer's first elements one by one up to its first 32-byte
// boundary, and the scalar and packet paths round differently (fused multiply-adds, exp and log): buffers aligned
// alike give every thread, and so any thread count, the same bits.
using AlignedFloats = std::vector<float, Eigen::aligned_allocator<float>>;

// Sub-sampled texels of a hemi-octahedral visibility map: local direction, solid angle and the visibility
// texel each lies in (row-major, as solver/transport.cc samples them).
struct TransportRenderer::TexelTable {
  int resolution = 0;  // of the visibility map
  std::vector<Eigen::Vector3f> dir_local;
  AlignedFloats dir_x, dir_y, dir_z;   // dir_local's coordinates, for vectorised loops
  std::vector<float> solid_angle_cos;  // Ω_j cos θ_j
  std::vector<int> parent;

  // `sub` sub-samples per texel side; 0: as the inverse stage's transport rows (TransportSupersampling).
  TexelTable(int n_local, int env_resolution, int sub) : resolution(n_local) {
    if (sub == 0) sub = TransportSupersampling(n_local, env_resolution, 0);
    const int n = sub * n_local;
    const std::vector<Eigen::Vector3d> dirs = HemiOctTexelDirections(n);
    const std::vector<double> omega = HemiOctTexelSolidAngles(n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const size_t j = size_t(y) * n + x;
        if (dirs[j].z() <= 0) continue;
        dir_local.push_back(dirs[j].cast<float>());
        dir_x.push_back(dir_local.back().x());
        dir_y.push_back(dir_local.back().y());
        dir_z.push_back(dir_local.back().z());
        solid_angle_cos.push_back(static_cast<float>(omega[j] * dirs[j].z()));
        parent.push_back((y / sub) * n_local + x / sub);
      }
  }
};

// Half the resolution of a visibility map, for the glossy lobes' adaptive quadrature: texel (i, j) holds the four
// visibility texels it covers (the hemi-octahedral parametrisation nests), its direction and solid angle.
struct TransportRenderer::CoarseTable {
  int resolution = 0;
  std::vector<Eigen::Vector3f> dir_local;
  AlignedFloats dir_x, dir_y, dir_z;  // dir_local's coordinates, for vectorised loops
  std::vector<float> solid_angle_cos;
  std::vector<std::array<int, 4>> children;

  explicit CoarseTable(int visibility_resolution) : resolution(visibility_resolution / 2) {
    const int n = resolution, fine = visibility_resolution;
    const std::vector<Eigen::Vector3d> dirs = HemiOctTexelDirections(n);
    const std::vector<double> omega = HemiOctTexelSolidAngles(n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const size_t j = size_t(y) * n + x;
        if (dirs[j].z() <= 0) continue;
        dir_local.push_back(dirs[j].cast<float>());
        dir_x.push_back(dir_local.back().x());
        dir_y.push_back(dir_local.back().y());
        dir_z.push_back(dir_local.back().z());
        solid_angle_cos.push_back(static_cast<float>(omega[j] * dirs[j].z()));
        children.push_back({2 * y * fine + 2 * x, 2 * y * fine + 2 * x + 1, (2 * y + 1) * fine + 2 * x,
                            (2 * y + 1) * fine + 2 * x + 1});
      }
  }
  // Coarse texel j covers the entries [fine_first[j], fine_first[j + 1]) of `fine`: indices into a
  // TexelTable of the visibility map's resolution.
  std::vector<uint32_t> fine_first, fine;

  void LinkFine(const std::vector<int>& fine_parent, int visibility_resolution) {
    std::vector<int> coarse_of(size_t(resolution) * resolution, -1);
    for (size_t j = 0; j < children.size(); ++j) {
      const int y = children[j][0] / visibility_resolution / 2, x = children[j][0] % visibility_resolution / 2;
      coarse_of[size_t(y) * resolution + x] = static_cast<int>(j);
    }
    std::vector<std::vector<uint32_t>> lists(children.size());
    for (size_t t = 0; t < fine_parent.size(); ++t) {
      const int py = fine_parent[t] / visibility_resolution, px = fine_parent[t] % visibility_resolution;
      const int j = coarse_of[size_t(py / 2) * resolution + px / 2];
      if (j >= 0) lists[j].push_back(static_cast<uint32_t>(t));
    }
    fine_first.assign(1, 0);
    for (const auto& list : lists) {
      fine.insert(fine.end(), list.begin(), list.end());
      fine_first.push_back(static_cast<uint32_t>(fine.size()));
    }
  }
  // Angular size of a texel [rad].
  double TexelAngle() const { return std::sqrt(2 * M_PI) / resolution; }
};

// Per surface: the dense visibility maps of the vertices used so far (8-bit fractions, 1/255 steps), and
// the radiance of the current view.
struct TransportRenderer::SurfaceState {
  struct LobeInfo {
    const BrdfLobe* lobe = nullptr;
    bool lambertian = false, phong = false;
    float half_cutoff = -2, mirror_cutoff = -2;  // texels beyond them are skipped (solver/transport.h)
    // Directions where the lobe is above 1 % of its peak, widened by a coarse texel: cosine of the angle to the
    // normal (half vector) or to the mirror direction (Phong) below which the coarse quadrature suffices
    // (2: everywhere, for a wide lobe).
    float core_cos = 2;
  };
  std::vector<LobeInfo> lobes;
  std::vector<int32_t> slot;  // vertex -> map index in `maps`, -1 when not yet decoded/baked
  std::vector<uint8_t> maps;
  size_t map_size = 0;
  std::vector<Eigen::Vector3f> view_radiance;
  std::vector<uint32_t> view_stamp;  // vertex -> id of the view its radiance belongs to

  // Per vertex (once decoded/baked): the Lambertian transport row, Σ_j V_j Ω_j cos θ_j splatted bilinearly
  // onto the global octahedral map, Haar-transformed and truncated as the inverse stage's rows are.
  std::vector<uint32_t> row_first, row_size;
  std::vector<uint16_t> row_index;
  std::vector<float> row_value;

  const uint8_t* Map(uint32_t v) const { return maps.data() + size_t(slot[v]) * map_size; }
};

namespace {

// Bilinear footprints of m world directions (any length > 0; structure of arrays) on an n x n octahedral map
// (docs/FORMATS.md), 8 at a time: per direction the texel (x0, y0) at the lower corner, as floats in [-1, n-1]
// (one step beyond the border where the direction lies within half a texel of it), and the weights fx, fy of the
// next column and row.
void OctFootprints(int m, const float* dx, const float* dy, const float* dz, int n, float* fx_out, float* fy_out,
                   float* x0_out, float* y0_out) {
  using ConstMap = Eigen::Map<const Eigen::ArrayXf>;
  Eigen::Map<Eigen::ArrayXf> u(fx_out, m), v(fy_out, m), fu(x0_out, m), fv(y0_out, m);
  const ConstMap x(dx, m), y(dy, m), z(dz, m);
  fu = x.abs() + y.abs() + z.abs();
  u = x / fu;
  v = y / fu;
  // Below the equator the octahedron's lower half is folded out over the square's corners.
  for (int k = 0; k < m; ++k) {
    if (!(dz[k] < 0)) continue;
    const float px = u[k], py = v[k];
    u[k] = (1 - std::abs(py)) * (px >= 0 ? 1.0f : -1.0f);
    v[k] = (1 - std::abs(px)) * (py >= 0 ? 1.0f : -1.0f);
  }
  u = (u * 0.5f + 0.5f) * float(n) - 0.5f;
  v = (v * 0.5f + 0.5f) * float(n) - 0.5f;
  fu = u.floor();
  fv = v.floor();
  u = (u - fu).max(0.0f).min(1.0f);
  v = (v - fv).max(0.0f).min(1.0f);
  fu = fu.max(-1.0f).min(float(n - 1));
  fv = fv.max(-1.0f).min(float(n - 1));
}

// An RGB octahedral map with a one-texel border copied across the folds, so bilinear reads need no wrapping.
struct PaddedOct {
  int n = 0;
  std::vector<Eigen::Array4f> rgb;  // (n+2)² texels, RGB and a zero (one aligned load per texel)

  explicit PaddedOct(const Image& oct = Image()) : n(oct.width) {
    if (n == 0) return;
    const int w = n + 2;
    rgb.assign(size_t(w) * w, Eigen::Array4f::Zero());
    for (int j = -1; j <= n; ++j)
      for (int i = -1; i <= n; ++i) {
        Eigen::Vector2i t(i, j);
        // An edge texel's neighbour across the fold; the corners (all at the nadir) wrap once per axis.
        if (t.x() < 0 || t.x() >= n) t = OctWrapTexel(t.x(), std::clamp(t.y(), 0, n - 1), n);
        if (j < 0 || j >= n) t = OctWrapTexel(t.x(), j, n);
        const int si = std::clamp(t.x(), 0, n - 1), sj = std::clamp(t.y(), 0, n - 1);
        for (int c = 0; c < 3; ++c) rgb[size_t(j + 1) * w + (i + 1)][c] = oct.at(si, sj, std::min(c, oct.channels - 1));
      }
  }

  // Σ_k L(d_k) ⊙ weight_k over m world directions (any length > 0; structure of arrays), L the bilinear
  // reconstruction of solver/transport.cc's splats, skipping zero weights: the footprints computed 8 at a time
  // into `scratch` (OctFootprints), then the texels read per direction.
  Eigen::Vector3f WeightedSum(int m, const float* dx, const float* dy, const float* dz, const float* wr,
                              const float* wg, const float* wb, AlignedFloats* scratch) const {
    scratch->resize(size_t(4) * m);
    Eigen::Map<Eigen::ArrayXf> u(scratch->data(), m), v(scratch->data() + m, m), fu(scratch->data() + 2 * m, m),
        fv(scratch->data() + 3 * m, m);
    OctFootprints(m, dx, dy, dz, n, u.data(), v.data(), fu.data(), fv.data());
    // The light per direction (into fu, fv and u, whose values are read first), then the weighted sums.
    for (int k = 0; k < m; ++k) {
      Eigen::Array4f light = Eigen::Array4f::Zero();
      if (wr[k] != 0 || wg[k] != 0 || wb[k] != 0)
        light = Texels4(static_cast<int>(fu[k]), static_cast<int>(fv[k]), u[k], v[k]);
      fu[k] = light[0];
      fv[k] = light[1];
      u[k] = light[2];
    }
    return Eigen::Vector3f((fu * Eigen::Map<const Eigen::ArrayXf>(wr, m)).sum(),
                           (fv * Eigen::Map<const Eigen::ArrayXf>(wg, m)).sum(),
                           (u * Eigen::Map<const Eigen::ArrayXf>(wb, m)).sum());
  }

 private:
  // The bilinear blend of the texels (x0, y0) to (x0 + 1, y0 + 1), x0, y0 in [-1, n-1] (OctFootprints).
  Eigen::Array4f Texels4(int x0, int y0, float fx, float fy) const {
    const size_t w = n + 2, i00 = size_t(y0 + 1) * w + (x0 + 1);
    return (1 - fy) * ((1 - fx) * rgb[i00] + fx * rgb[i00 + 1]) +
           fy * ((1 - fx) * rgb[i00 + w] + fx * rgb[i00 + w + 1]);
  }
};

// The directions of one vertex's glossy quadrature (local, structure of arrays) with their weights V Ω cos, and
// the scratch GlossySum evaluates them in (kept per thread, so that no vertex allocates once it has grown).
struct GlossyDirections {
  int size = 0;
  AlignedFloats x, y, z, weight;
  AlignedFloats cos_h, o_dot_h, cos_mirror, f, r, g, b, wx, wy, wz, footprint;

  // Room for `capacity` directions; empties the list.
  void Reset(size_t capacity) {
    size = 0;
    if (x.size() >= capacity) return;
    for (AlignedFloats* v : {&x, &y, &z, &weight, &cos_h, &o_dot_h, &cos_mirror, &f, &r, &g, &b, &wx, &wy, &wz})
      v->resize(capacity);
  }
  void Add(const Eigen::Vector3f& d, float w) {
    x[size] = d.x();
    y[size] = d.y();
    z[size] = d.z();
    weight[size++] = w;
  }
};

// A glossy lobe of a vertex: its BRDF, where it is cut off (solver/transport.h) and its RGB coefficient.
struct GlossyLobe {
  const BrdfLobe* lobe = nullptr;
  bool phong = false;
  float half_cutoff = -2, mirror_cutoff = -2;
  Eigen::Vector3f rgb = Eigen::Vector3f::Zero();
};

// Σ_d Σ_g k_g f_g(d, wo) · weight_d · L(frame · d) over the gathered directions: the lobes evaluated 8 directions
// at a time (BrdfLobe::EvalCosinesBatch), zero beyond their cutoffs, and the light read where the sum is non-zero.
Eigen::Vector3f GlossySum(const PaddedOct& light, const LocalFrame<float>& frame, const Eigen::Vector3f& wo,
                          int num_lobes, const GlossyLobe* lobes, GlossyDirections* dirs) {
  using Map = Eigen::Map<Eigen::ArrayXf>;
  const int m = dirs->size;
  const Map x(dirs->x.data(), m), y(dirs->y.data(), m), z(dirs->z.data(), m), weight(dirs->weight.data(), m);
  Map cos_h(dirs->cos_h.data(), m), o_dot_h(dirs->o_dot_h.data(), m), cos_mirror(dirs->cos_mirror.data(), m),
      f(dirs->f.data(), m), r(dirs->r.data(), m), g(dirs->g.data(), m), b(dirs->b.data(), m);
  // The half vector h = (d + wo) / |d + wo|; f holds 1 / |d + wo| for now.
  f = ((x + wo.x()).square() + (y + wo.y()).square() + (z + wo.z()).square()).sqrt().inverse();
  cos_h = (z + wo.z()) * f;
  o_dot_h = ((wo.x() * (x + wo.x()) + wo.y() * (y + wo.y()) + wo.z() * (z + wo.z())) * f).max(0.0f);
  cos_mirror = z * wo.z() - x * wo.x() - y * wo.y();  // d · (−wo.x, −wo.y, wo.z)
  r.setZero();
  g.setZero();
  b.setZero();
  for (int k = 0; k < num_lobes; ++k) {
    const GlossyLobe& lobe = lobes[k];
    lobe.lobe->EvalCosinesBatch(wo.z(), m, dirs->z.data(), dirs->cos_h.data(), dirs->o_dot_h.data(),
                                dirs->cos_mirror.data(), dirs->f.data());
    if (lobe.phong) {
      f = (cos_mirror >= lobe.mirror_cutoff).select(f, 0.0f);
    } else {
      f = (cos_h >= lobe.half_cutoff).select(f, 0.0f);
    }
    r += lobe.rgb.x() * f;
    g += lobe.rgb.y() * f;
    b += lobe.rgb.z() * f;
  }
  r *= weight;
  g *= weight;
  b *= weight;
  Map(dirs->wx.data(), m) = frame.tangent.x() * x + frame.bitangent.x() * y + frame.normal.x() * z;
  Map(dirs->wy.data(), m) = frame.tangent.y() * x + frame.bitangent.y() * y + frame.normal.y() * z;
  Map(dirs->wz.data(), m) = frame.tangent.z() * x + frame.bitangent.z() * y + frame.normal.z() * z;
  return light.WeightedSum(m, dirs->wx.data(), dirs->wy.data(), dirs->wz.data(), dirs->r.data(), dirs->g.data(),
                           dirs->b.data(), &dirs->footprint);
}

// The four texels (row-major indices) and bilinear weights of the footprint OctFootprints gives a direction on an
// n x n octahedral map, wrapped across the folds: the transpose of PaddedOct's reconstruction, as solver/transport.cc
// splats.
void OctSplatFootprint(int x0, int y0, float fx, float fy, int n, std::array<int, 4>* index,
                       std::array<float, 4>* weight) {
  const int dx[4] = {0, 1, 0, 1}, dy[4] = {0, 0, 1, 1};
  const float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector2i t(x0 + dx[k], y0 + dy[k]);
    if (t.x() < 0 || t.x() >= n) t = OctWrapTexel(t.x(), std::clamp(t.y(), 0, n - 1), n);
    if (y0 + dy[k] < 0 || y0 + dy[k] >= n) t = OctWrapTexel(t.x(), y0 + dy[k], n);
    (*index)[k] = std::clamp(t.y(), 0, n - 1) * n + std::clamp(t.x(), 0, n - 1);
    (*weight)[k] = w[k];
  }
}

// Lambertian rows keep the fewest Haar coefficients holding this share of their energy, at most
// kRowMaxCoefficients (EnergyTruncator, as the inverse stage's rows): its defaults (inverse.keep_energy,
// inverse.max_coefficients).
constexpr double kRowKeepEnergy = 0.999;
constexpr int kRowMaxCoefficients = 256;

}  // namespace

// What is kept for one light: the environment filtered to the octahedral map (texels and their Haar
// coefficients), per vertex the Lambertian part of the radiance, the shadow-ray results of the delta
// lights and, with the bounce, what each object vertex receives.
struct TransportRenderer::LightState {
  const Lighting* lighting = nullptr;
  bool has_env = false;
  PaddedOct light;
  std::array<std::vector<float>, 3> haar;             // per channel: the Haar coefficients of the filtered map
  std::vector<std::vector<Eigen::Vector3f>> diffuse;  // [surface][vertex]
  std::vector<std::vector<uint8_t>> diffuse_done;     // [surface][vertex]
  std::vector<std::vector<uint8_t>> delta_unblocked;  // [surface][vertex * num_delta + k]: 0 unknown, 1 lit, 2 blocked
  std::vector<DirectionalLight> suns;                 // split out of the environment (render/sun_light.h)
  size_t num_delta = 0;
  std::vector<Eigen::Vector3f> bounce_in;  // object vertex: Σ_s w_s D_{h_s} (header comment); empty: no bounce
};

TransportRenderer::TransportRenderer(const Scene& scene, const VisibilityData& object_visibility, int env_resolution)
    : scene_(scene), object_visibility_(object_visibility), env_resolution_(env_resolution) {
  RELIGHT_CHECK(scene.num_surfaces() >= 1);
  if (object_visibility.per_vertex.size() != scene.surface(0).mesh.num_vertices()) {
    RELIGHT_USER_ERROR() << "the visibility maps hold " << object_visibility.per_vertex.size()
                         << " vertices but the recovered model has " << scene.surface(0).mesh.num_vertices()
                         << "; rerun the visibility and inverse stages on the same mesh";
  }
  RELIGHT_CHECK(env_resolution >= 2 && (env_resolution & (env_resolution - 1)) == 0) << env_resolution;
  object_texels_ = std::make_unique<TexelTable>(object_visibility.resolution, env_resolution, 0);
  occluder_texels_ = std::make_unique<TexelTable>(kOccluderVisibilityResolution, env_resolution, 1);
  // Rows are built once per vertex: sampled at 64² directions per hemisphere (each visibility texel's value
  // held), so a light sharper than the hemisphere's texels is integrated rather than point-sampled.
  object_row_texels_ = std::make_unique<TexelTable>(object_visibility.resolution, env_resolution,
                                                    std::max(1, 64 / object_visibility.resolution));
  occluder_row_texels_ = std::make_unique<TexelTable>(kOccluderVisibilityResolution, env_resolution,
                                                      std::max(1, 64 / kOccluderVisibilityResolution));
  if (object_visibility.resolution >= 16) {
    object_coarse_ = std::make_unique<CoarseTable>(object_visibility.resolution);
    object_coarse_->LinkFine(object_texels_->parent, object_visibility.resolution);
  }
  for (int s = 0; s < scene.num_surfaces(); ++s) {
    auto state = std::make_unique<SurfaceState>();
    const size_t nv = scene.surface(s).mesh.num_vertices();
    state->slot.assign(nv, -1);
    state->row_first.assign(nv, 0);
    state->row_size.assign(nv, 0);
    for (const BrdfLobe& lobe : scene.surface(s).reflectance.basis) {
      SurfaceState::LobeInfo info;
      info.lobe = &lobe;
      info.lambertian = lobe.model == BrdfModel::kLambertian;
      info.phong = lobe.model == BrdfModel::kPhong;
      info.half_cutoff = static_cast<float>(LobeHalfVectorCutoff(lobe));
      info.mirror_cutoff = static_cast<float>(PhongMirrorCutoff(lobe));
      if (info.half_cutoff <= -1) info.half_cutoff = -2;
      if (info.mirror_cutoff <= -1) info.mirror_cutoff = -2;
      if (s == 0 && object_coarse_ && !info.lambertian) {
        const double margin = object_coarse_->TexelAngle();
        double core = 0;  // [rad]
        if (info.phong) {
          core = std::acos(std::pow(0.01, 1.0 / lobe.exponent)) + margin;
        } else {
          // D(θ_h) / D(0) = 0.01: GGX (α² / (α² + tan²θ_h))² cos⁻⁴θ_h ≈ …, Beckmann exp(−tan²θ_h / α²) cos⁻⁴θ_h;
          // found by a scan as LobeHalfVectorCutoff does, then widened by half a texel (half-vector angles).
          const double a2 = lobe.roughness * lobe.roughness;
          for (int k = 1; k <= 900; ++k) {
            const double th = k * (M_PI / 2) / 900.0, c2 = std::cos(th) * std::cos(th), t2 = (1 - c2) / c2;
            const double ratio = lobe.model == BrdfModel::kCookTorrance ? std::exp(-t2 / a2) / (c2 * c2)
                                                                        : a2 * a2 / (c2 * c2 * (a2 + t2) * (a2 + t2));
            core = th;
            if (ratio < 0.01) break;
          }
          core += 0.5 * margin;
        }
        info.core_cos = static_cast<float>(std::cos(std::min(core, M_PI)));
        // A lobe at least three coarse texels wide (half-width in incident directions: about twice the half
        // vector's for microfacets, where a Phong lobe halves) is resolved by the coarse texels everywhere.
        const double half_width =
            info.phong ? std::acos(std::pow(0.5, 1.0 / lobe.exponent)) : 2 * std::atan(lobe.roughness);
        if (half_width >= 3 * margin) info.core_cos = 2;
      }
      state->lobes.push_back(info);
    }
    state->map_size = s == 0 ? size_t(object_visibility.resolution) * object_visibility.resolution
                             : size_t(kOccluderVisibilityResolution) * kOccluderVisibilityResolution;
    state->view_radiance.assign(nv, Eigen::Vector3f::Zero());
    state->view_stamp.assign(nv, 0);
    surfaces_.push_back(std::move(state));
  }
  ray_offset_ = static_cast<float>(1e-4 * scene.diagonal()) + scene.caster().Epsilon();
}

TransportRenderer::~TransportRenderer() = default;

int64_t TransportRenderer::NumBands(const Camera& camera, const TransportRenderOptions& o) {
  return (camera.height + o.band_rows - 1) / std::max(1, o.band_rows);
}

void TransportRenderer::Forget(const Lighting& lighting) { lights_.erase(&lighting); }

TransportRenderer::LightState& TransportRenderer::Prepare(const Lighting& lighting) {
  auto it = lights_.find(&lighting);
  if (it != lights_.end()) return *it->second;
  auto state = std::make_unique<LightState>();
  const int n = env_resolution_;
  state->lighting = &lighting;
  if (lighting.env && !lighting.env->empty()) {
    state->has_env = true;
    // A sun sharper than a texel of the filtered map is taken out and traced as a delta light.
    SunSplit split = SplitSun(*lighting.env, 0.5 * std::sqrt(4 * M_PI) / n);
    if (split.found) {
      state->suns.push_back(split.sun);
      const Eigen::Vector3d& d = split.sun.dir_world;
      RLOG_DEBUG(
          "transport renderer: a sun split out of the light as a delta light ({:.0f}% of its light, {:.1f} deg "
          "above the horizon)",
          100 * split.share, std::asin(std::clamp(d.z(), -1.0, 1.0)) * 180 / M_PI);
    }
    const EnvMap& env = split.found ? split.residual : *lighting.env;
    Image oct;
    // A recovered map at the model's resolution is the model's own light: its texels, unfiltered.
    if (env.layout() == EnvMap::Layout::kOctahedral && env.image().width == n && env.intensity() == 1.0 &&
        env.rotation_world().isIdentity(0)) {
      oct = env.image();
    } else {
      // Texel averages (a texel spans sqrt(4 pi) / n on average).
      oct = env.ToOctahedral(n, env.CoveringSupersampling(std::sqrt(4 * M_PI) / n));
    }
    state->light = PaddedOct(oct);
    for (int c = 0; c < 3; ++c) {
      std::vector<float> channel(size_t(n) * n);
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) channel[size_t(j) * n + i] = oct.at(i, j, std::min(c, oct.channels - 1));
      state->haar[c].resize(channel.size());
      HaarForward(channel.data(), n, state->haar[c].data());
    }
  }
  state->num_delta = lighting.directional.size() + state->suns.size() + lighting.points.size();
  for (int s = 0; s < scene_.num_surfaces(); ++s) {
    const size_t nv = scene_.surface(s).mesh.num_vertices();
    state->diffuse.emplace_back(nv, Eigen::Vector3f::Zero());
    state->diffuse_done.emplace_back(nv, 0);
    state->delta_unblocked.emplace_back(nv * state->num_delta, 0);
  }
  LightState& ref = *state;
  lights_[&lighting] = std::move(state);
  if (interreflection_) PrepareBounce(&ref);
  return ref;
}

InterreflectionSummary TransportRenderer::EnableInterreflection(const BounceOptions& options, bool occluders_bounce) {
  Timer timer;
  // The occluders (surface 1, the caster's mesh 1) reflect their recovered (or given) albedo onto the object.
  const bool occluders = occluders_bounce && scene_.num_surfaces() > 1;
  bounce_ =
      ComputeBounceSamples(scene_.surface(0).mesh, scene_.caster(), options, occluders ? &occluder_bounce_ : nullptr);
  occluder_bounce_vertices_.clear();
  if (occluders) {
    std::vector<char> hit(scene_.surface(1).mesh.num_vertices(), 0);
    for (uint32_t h : occluder_bounce_.hit_vertex) hit[h] = 1;
    for (size_t h = 0; h < hit.size(); ++h)
      if (hit[h]) occluder_bounce_vertices_.push_back(static_cast<uint32_t>(h));
  }
  interreflection_ = true;
  lights_.clear();  // their radiance lacks the bounce
  InterreflectionSummary summary;
  summary.num_samples = bounce_.hit_vertex.size() + occluder_bounce_.hit_vertex.size();
  summary.seconds = timer.Seconds();
  return summary;
}

void TransportRenderer::BuildObjectRows() {
  std::vector<uint32_t> all(surfaces_[0]->slot.size());
  std::iota(all.begin(), all.end(), 0u);
  EnsureOccluderVisibility(0, all);
}

TransportRenderer::Row TransportRenderer::ObjectRow(uint32_t vertex) const {
  const SurfaceState& st = *surfaces_[0];
  RELIGHT_CHECK(vertex < st.slot.size() && st.slot[vertex] >= 0) << "vertex " << vertex << " has no row yet";
  const uint32_t first = st.row_first[vertex];
  return Row{st.row_index.data() + first, st.row_value.data() + first, st.row_size[vertex]};
}

void TransportRenderer::EnsureOccluderVisibility(int surface, const std::vector<uint32_t>& vertices) {
  SurfaceState& st = *surfaces_[surface];
  std::vector<uint32_t> missing;
  for (uint32_t v : vertices)
    if (st.slot[v] < 0) missing.push_back(v);
  if (missing.empty()) return;
  const size_t first = st.maps.size() / st.map_size;
  st.maps.resize(st.maps.size() + missing.size() * st.map_size);
  for (size_t q = 0; q < missing.size(); ++q) st.slot[missing[q]] = static_cast<int32_t>(first + q);
  if (surface == 0) {
    tbb::parallel_for(size_t(0), missing.size(), [&](size_t q) {
      const std::vector<float> dense = object_visibility_.DenseMap(missing[q]);
      uint8_t* out = st.maps.data() + (first + q) * st.map_size;
      for (size_t k = 0; k < st.map_size; ++k)
        out[k] = static_cast<uint8_t>(std::lround(std::clamp(dense[k], 0.0f, 1.0f) * 255.0f));
    });
  } else {
    VisibilityOptions vo;
    vo.resolution = kOccluderVisibilityResolution;
    vo.supersampling = 1;
    std::vector<float> dense;
    BakeVisibilityMaps(scene_.surface(surface).mesh, scene_.caster(), missing, vo, &dense);
    for (size_t k = 0; k < missing.size() * st.map_size; ++k)
      st.maps[first * st.map_size + k] = static_cast<uint8_t>(std::lround(std::clamp(dense[k], 0.0f, 1.0f) * 255.0f));
  }
  // Lambertian rows (solver/transport.cc's pixel route for a Lambertian lobe, without the 1/π).
  const TexelTable& table = surface == 0 ? *object_row_texels_ : *occluder_row_texels_;
  const int n = env_resolution_;
  std::vector<std::pair<std::vector<uint16_t>, std::vector<float>>> rows(missing.size());
  tbb::parallel_for(size_t(0), missing.size(), [&](size_t q) {
    const uint32_t v = missing[q];
    const uint8_t* vis = st.Map(v);
    const LocalFrame<float> frame = FrameFromNormal<float>(scene_.surface(surface).mesh.normals[v].normalized());
    std::vector<float> pixels(size_t(n) * n, 0.0f), coeffs(size_t(n) * n);
    // The directions' world coordinates and footprints 8 at a time, then the splats one by one (wrapped across
    // the folds only at the map's border).
    const int m = static_cast<int>(table.dir_local.size());
    thread_local AlignedFloats buffer;
    buffer.resize(size_t(7) * m);
    float *wx = buffer.data(), *wy = wx + m, *wz = wy + m, *fx = wz + m, *fy = fx + m, *x0 = fy + m, *y0 = x0 + m;
    {
      using ConstMap = Eigen::Map<const Eigen::ArrayXf>;
      const ConstMap x(table.dir_x.data(), m), y(table.dir_y.data(), m), z(table.dir_z.data(), m);
      Eigen::Map<Eigen::ArrayXf>(wx, m) = frame.tangent.x() * x + frame.bitangent.x() * y + frame.normal.x() * z;
      Eigen::Map<Eigen::ArrayXf>(wy, m) = frame.tangent.y() * x + frame.bitangent.y() * y + frame.normal.y() * z;
      Eigen::Map<Eigen::ArrayXf>(wz, m) = frame.tangent.z() * x + frame.bitangent.z() * y + frame.normal.z() * z;
    }
    OctFootprints(m, wx, wy, wz, n, fx, fy, x0, y0);
    for (int j = 0; j < m; ++j) {
      const uint8_t vq = vis[table.parent[j]];
      if (vq == 0) continue;
      const float w = vq * (1.0f / 255.0f) * table.solid_angle_cos[j];
      const int tx = static_cast<int>(x0[j]), ty = static_cast<int>(y0[j]);
      if (tx >= 0 && ty >= 0 && tx + 1 < n && ty + 1 < n) {
        float* p = pixels.data() + size_t(ty) * n + tx;
        p[0] += w * (1 - fx[j]) * (1 - fy[j]);
        p[1] += w * fx[j] * (1 - fy[j]);
        p[n] += w * (1 - fx[j]) * fy[j];
        p[n + 1] += w * fx[j] * fy[j];
        continue;
      }
      std::array<int, 4> idx;
      std::array<float, 4> wt;
      OctSplatFootprint(tx, ty, fx[j], fy[j], n, &idx, &wt);
      for (int k = 0; k < 4; ++k) pixels[idx[k]] += w * wt[k];
    }
    HaarForward(pixels.data(), n, coeffs.data());
    thread_local EnergyTruncator truncator;
    truncator.Run(coeffs.data(), n * n, kRowKeepEnergy, kRowMaxCoefficients, &rows[q].first, &rows[q].second);
  });
  for (size_t q = 0; q < missing.size(); ++q) {
    st.row_first[missing[q]] = static_cast<uint32_t>(st.row_index.size());
    st.row_size[missing[q]] = static_cast<uint32_t>(rows[q].first.size());
    st.row_index.insert(st.row_index.end(), rows[q].first.begin(), rows[q].first.end());
    st.row_value.insert(st.row_value.end(), rows[q].second.begin(), rows[q].second.end());
  }
}

const Eigen::Vector3f& TransportRenderer::DiffuseEnv(LightState* light, int surface, uint32_t vertex,
                                                     const Eigen::Vector3f& lambert_rgb) {
  if (!light->diffuse_done[surface][vertex]) {
    // The vertex's Lambertian row against the light's Haar coefficients.
    const SurfaceState& st = *surfaces_[surface];
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    const uint32_t first = st.row_first[vertex];
    for (uint32_t k = first; k < first + st.row_size[vertex]; ++k)
      for (int c = 0; c < 3; ++c) sum[c] += st.row_value[k] * light->haar[c][st.row_index[k]];
    light->diffuse[surface][vertex] = lambert_rgb.cwiseProduct(sum) * static_cast<float>(1.0 / M_PI);
    light->diffuse_done[surface][vertex] = 1;
  }
  return light->diffuse[surface][vertex];
}

template <typename Fn>
void TransportRenderer::ForEachUnblockedDelta(LightState* light, int surface, uint32_t vertex,
                                              const Eigen::Vector3f& normal_world, Fn&& fn) {
  if (light->num_delta == 0) return;
  const Lighting& lighting = *light->lighting;
  const Eigen::Vector3f x = scene_.surface(surface).mesh.vertices[vertex];
  auto visit = [&](size_t k, const Eigen::Vector3f& to_light, float distance, const Eigen::Vector3f& irradiance) {
    const float cos_i = normal_world.dot(to_light);
    if (cos_i <= 0) return;
    uint8_t& state = light->delta_unblocked[surface][size_t(vertex) * light->num_delta + k];
    if (state == 0) {
      Ray ray;
      ray.origin = x + ray_offset_ * normal_world;
      ray.dir = to_light;
      ray.t_far = distance;
      state = scene_.caster().Occluded(ray) ? 2 : 1;
    }
    if (state == 1) fn(to_light, cos_i, irradiance);
  };
  size_t k = 0;
  for (const std::vector<DirectionalLight>* list : {&lighting.directional, &std::as_const(light->suns)})
    for (const DirectionalLight& d : *list)
      visit(k++, d.dir_world.normalized().cast<float>(), std::numeric_limits<float>::infinity(),
            d.irradiance_rgb.cast<float>());
  for (const PointLight& p : lighting.points) {
    const Eigen::Vector3f to = p.position_world.cast<float>() - x;
    const float r = to.norm();
    if (r > 0) visit(k, to / r, r * (1 - 1e-4f), p.intensity_rgb.cast<float>() / (r * r));
    ++k;
  }
}

std::vector<float> TransportRenderer::DiffuseExit(LightState* light, int surface,
                                                  const std::vector<uint32_t>& vertices) {
  const SurfaceState& st = *surfaces_[surface];
  // The Lambertian rows of the listed vertices (the object's maps decoded, occluders' baked), kept for later views.
  if (light->has_env) EnsureOccluderVisibility(surface, vertices);
  std::vector<float> exit_rgb(scene_.surface(surface).mesh.num_vertices() * 3, 0.0f);
  tbb::parallel_for(size_t(0), vertices.size(), [&](size_t q) {
    const uint32_t vertex = vertices[q];
    const SurfacePoint point = scene_.PointAtVertex(surface, static_cast<int>(vertex));
    Eigen::Vector3f lambert_rgb = Eigen::Vector3f::Zero();  // the lobes Shade counts as Lambertian
    for (int b = 0; b < point.num_lobes; ++b) {
      const Eigen::Vector3f k = point.lobe_rgb[b].cast<float>();
      if (k.maxCoeff() > 0 && st.lobes[b].lambertian) lambert_rgb += k;
    }
    if (lambert_rgb.maxCoeff() <= 0) return;
    Eigen::Vector3f exit = Eigen::Vector3f::Zero();
    if (light->has_env) exit += DiffuseEnv(light, surface, vertex, lambert_rgb);
    const Eigen::Vector3f f_rgb = lambert_rgb * static_cast<float>(1.0 / M_PI);
    ForEachUnblockedDelta(light, surface, vertex, point.normal_shading_world.cast<float>(),
                          [&](const Eigen::Vector3f&, float cos_i, const Eigen::Vector3f& irradiance) {
                            exit += cos_i * f_rgb.cwiseProduct(irradiance);
                          });
    for (int c = 0; c < 3; ++c) exit_rgb[size_t(vertex) * 3 + c] = exit[c];
  });
  return exit_rgb;
}

void TransportRenderer::PrepareBounce(LightState* light) {
  Timer timer;
  const size_t nv = scene_.surface(0).mesh.num_vertices();
  // D_h of every object vertex (any can be hit), and of the occluder vertices the object sees.
  std::vector<uint32_t> all(nv);
  for (size_t v = 0; v < nv; ++v) all[v] = static_cast<uint32_t>(v);
  const std::vector<float> exit_rgb = DiffuseExit(light, 0, all);
  std::vector<float> occluder_exit_rgb;
  if (!occluder_bounce_vertices_.empty()) occluder_exit_rgb = DiffuseExit(light, 1, occluder_bounce_vertices_);
  light->bounce_in.assign(nv, Eigen::Vector3f::Zero());
  tbb::parallel_for(size_t(0), nv, [&](size_t v) {
    for (int c = 0; c < 3; ++c) {
      light->bounce_in[v][c] = bounce_.Gather(static_cast<uint32_t>(v), exit_rgb.data(), 3, c);
      if (!occluder_exit_rgb.empty())
        light->bounce_in[v][c] += occluder_bounce_.Gather(static_cast<uint32_t>(v), occluder_exit_rgb.data(), 3, c);
    }
  });
  RLOG_DEBUG("transport renderer: the bounce under a light over {} vertices in {:.2f} s", nv, timer.Seconds());
}

Eigen::Vector3f TransportRenderer::Shade(const LightState& light, int surface, uint32_t vertex,
                                         const Eigen::Vector3f& dir_out_world) {
  const SurfaceState& st = *surfaces_[surface];
  const SurfacePoint point = scene_.PointAtVertex(surface, static_cast<int>(vertex));
  const Eigen::Vector3f normal = point.normal_shading_world.cast<float>();
  const LocalFrame<float> frame = FrameFromNormal<float>(normal);
  const Eigen::Matrix3f local_from_world = frame.LocalFromWorld();
  Eigen::Vector3f wo = local_from_world * dir_out_world;
  // Seen at or behind its horizon (interpolated normals at a silhouette): the horizon's value.
  wo.z() = std::max(wo.z(), 1e-3f);
  wo.normalize();
  Eigen::Vector3f lambert_rgb = Eigen::Vector3f::Zero();
  std::array<int, kMaxLobes> glossy{};  // lobes of the vertex with a non-zero coefficient
  std::array<Eigen::Vector3f, kMaxLobes> glossy_rgb;
  int num_glossy = 0;
  for (int b = 0; b < point.num_lobes; ++b) {
    const Eigen::Vector3f k = point.lobe_rgb[b].cast<float>();
    if (k.maxCoeff() <= 0) continue;
    if (st.lobes[b].lambertian) {
      lambert_rgb += k;
    } else {
      glossy[num_glossy] = b;
      glossy_rgb[num_glossy++] = k;
    }
  }
  Eigen::Vector3f radiance = Eigen::Vector3f::Zero();
  LightState& mutable_light = const_cast<LightState&>(light);
  if (light.has_env) {
    const TexelTable& table = surface == 0 ? *object_texels_ : *occluder_texels_;
    const uint8_t* vis = st.Map(vertex);
    // The directions to sum (local, with their weight V Ω cos, V in 1/255 steps), gathered first so the lobes
    // and the light are evaluated over all of them at once (GlossySum).
    thread_local GlossyDirections dirs;
    dirs.Reset(table.dir_local.size() + (object_coarse_ ? object_coarse_->dir_local.size() : 0));
    if (num_glossy > 0 && surface == 0 && object_coarse_) {
      // Adaptive quadrature: the coarse texels (2 x 2 visibility texels each) where some lobe is near its
      // peak (its core) are summed over their fine texels, the others (the lobes' tails, smooth) at their
      // centre with the mean visibility.
      const CoarseTable& coarse = *object_coarse_;
      // A coarse texel is a core one where its cosine to the mirror direction (Phong) or its half vector's to the
      // normal (microfacets) reaches the least core cosine of the vertex's lobes of that kind.
      float phong_core = 2, microfacet_core = 2;
      for (int g = 0; g < num_glossy; ++g) {
        const SurfaceState::LobeInfo& lobe = st.lobes[glossy[g]];
        float& core = lobe.phong ? phong_core : microfacet_core;
        core = std::min(core, lobe.core_cos);
      }
      const int nc = static_cast<int>(coarse.dir_local.size());
      using Map = Eigen::Map<const Eigen::ArrayXf>;
      const Map cx(coarse.dir_x.data(), nc), cy(coarse.dir_y.data(), nc), cz(coarse.dir_z.data(), nc);
      Eigen::Map<Eigen::ArrayXf> core_mirror(dirs.cos_mirror.data(), nc), core_half(dirs.cos_h.data(), nc);
      core_mirror = cz * wo.z() - cx * wo.x() - cy * wo.y();
      core_half = (cz + wo.z()) * ((cx + wo.x()).square() + (cy + wo.y()).square() + (cz + wo.z()).square()).rsqrt();
      for (int j = 0; j < nc; ++j) {
        const std::array<int, 4>& c = coarse.children[j];
        const int vq = vis[c[0]] + vis[c[1]] + vis[c[2]] + vis[c[3]];
        if (vq == 0) continue;
        const Eigen::Vector3f& d = coarse.dir_local[j];
        const bool core = core_mirror[j] >= phong_core || core_half[j] >= microfacet_core;
        if (!core) {
          dirs.Add(d, 0.25f * vq * coarse.solid_angle_cos[j]);
          continue;
        }
        for (uint32_t q = coarse.fine_first[j]; q < coarse.fine_first[j + 1]; ++q) {
          const uint32_t t = coarse.fine[q];
          const uint8_t v = vis[table.parent[t]];
          if (v > 0) dirs.Add(table.dir_local[t], v * table.solid_angle_cos[t]);
        }
      }
    } else if (num_glossy > 0) {
      for (size_t j = 0; j < table.dir_local.size(); ++j) {
        const uint8_t v = vis[table.parent[j]];
        if (v > 0) dirs.Add(table.dir_local[j], v * table.solid_angle_cos[j]);
      }
    }
    if (dirs.size > 0) {
      std::array<GlossyLobe, kMaxLobes> lobes;
      for (int g = 0; g < num_glossy; ++g) {
        const SurfaceState::LobeInfo& info = st.lobes[glossy[g]];
        lobes[g] = {info.lobe, info.phong, info.half_cutoff, info.mirror_cutoff, glossy_rgb[g]};
      }
      radiance += (1.0f / 255.0f) * GlossySum(light.light, frame, wo, num_glossy, lobes.data(), &dirs);
    }
    radiance += DiffuseEnv(&mutable_light, surface, vertex, lambert_rgb);
  }
  // Delta lights, with one shadow ray each (kept per light).
  ForEachUnblockedDelta(&mutable_light, surface, vertex, normal,
                        [&](const Eigen::Vector3f& to_light, float cos_i, const Eigen::Vector3f& irradiance) {
                          const Eigen::Vector3f wi = local_from_world * to_light;
                          Eigen::Vector3f fr = lambert_rgb * static_cast<float>(1.0 / M_PI);
                          for (int g = 0; g < num_glossy; ++g)
                            fr += glossy_rgb[g] * st.lobes[glossy[g]].lobe->Eval<float>(wi, wo);
                          radiance += cos_i * fr.cwiseProduct(irradiance);
                        });
  // The bounce from the object's other vertices reaches its Lambertian lobes.
  if (surface == 0 && !light.bounce_in.empty()) radiance += lambert_rgb.cwiseProduct(light.bounce_in[vertex]);
  return radiance;
}

Eigen::Vector3f TransportRenderer::VertexRadiance(const Lighting& lighting, int surface, int vertex,
                                                  const Eigen::Vector3f& dir_out_world) {
  RELIGHT_CHECK(surface >= 0 && surface < scene_.num_surfaces());
  LightState& light = Prepare(lighting);
  EnsureOccluderVisibility(surface, {static_cast<uint32_t>(vertex)});
  return Shade(light, surface, static_cast<uint32_t>(vertex), dir_out_world);
}

RenderedView TransportRenderer::Render(const Lighting& lighting, const Camera& camera, const ImageRecord& pose,
                                       const TransportRenderOptions& o, Progress* progress) {
  Timer timer;
  RELIGHT_CHECK(o.pixel_samples_per_axis >= 1 && o.band_rows >= 1);
  LightState& light = Prepare(lighting);
  const uint32_t view_id = ++views_rendered_;
  const int width = camera.width, height = camera.height, k = o.pixel_samples_per_axis;
  RenderedView out;
  out.radiance = Image(width, height, 3);
  out.mask = Image(width, height, 1);
  out.coverage = Image(width, height, 1);
  out.depth = Image(width, height, 1);
  out.surface = Image(width, height, 1);
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  const Eigen::Vector3f center = pose.ProjectionCenter().cast<float>();
  const Eigen::Vector3f cam_z = world_from_cam.col(2).cast<float>();
  const int ns = scene_.num_surfaces();
  std::vector<Ray> rays;
  std::vector<RayHit> hits;
  for (int y0 = 0; y0 < height; y0 += o.band_rows) {
    const int y1 = std::min(height, y0 + o.band_rows);
    // Camera rays: k×k per pixel, then the pixel-centre ray (mask, depth, surface). Directions are exact at
    // the pixel corners and bilinear inside a pixel: exact for a pinhole, and within far less than a pixel's
    // width of the exact ray for lens distortion, which varies smoothly (the exact ray per sample cost more
    // than the shading).
    const size_t per_pixel = size_t(k) * k + 1;
    const int lattice_width = width + 1;
    std::vector<Eigen::Vector3f> corner(size_t(y1 - y0 + 1) * lattice_width);
    tbb::parallel_for(y0, y1 + 1, [&](int y) {
      for (int x = 0; x <= width; ++x)
        corner[size_t(y - y0) * lattice_width + x] =
            (world_from_cam * camera.RayFromImage(Eigen::Vector2d(x, y))).normalized().cast<float>();
    });
    rays.resize(size_t(y1 - y0) * width * per_pixel);  // each ray's origin and direction are set below
    tbb::parallel_for(y0, y1, [&](int y) {
      for (int x = 0; x < width; ++x) {
        const Eigen::Vector3f* c0 = corner.data() + size_t(y - y0) * lattice_width + x;
        const Eigen::Vector3f* c1 = c0 + lattice_width;
        Ray* r = rays.data() + (size_t(y - y0) * width + x) * per_pixel;
        for (size_t q = 0; q < per_pixel; ++q) {
          const float sx = q + 1 == per_pixel ? 0.5f : (float(q % k) + 0.5f) / k;
          const float sy = q + 1 == per_pixel ? 0.5f : (float(q / k) + 0.5f) / k;
          r[q].origin = center;
          r[q].dir = (1 - sy) * ((1 - sx) * c0[0] + sx * c0[1]) + sy * ((1 - sx) * c1[0] + sx * c1[1]);
        }
      }
    });
    scene_.caster().IntersectStream(rays, true, &hits);
    // Vertices this band needs and the current view has not shaded yet.
    std::vector<std::vector<uint32_t>> needed(ns);
    for (const RayHit& hit : hits) {
      if (!hit.hit) continue;
      const int s = static_cast<int>(hit.geom_id);
      SurfaceState& st = *surfaces_[s];
      const Eigen::Vector3i& f = scene_.surface(s).mesh.faces[hit.prim_id];
      for (int c = 0; c < 3; ++c)
        if (st.view_stamp[f[c]] != view_id) {
          st.view_stamp[f[c]] = view_id;
          needed[s].push_back(static_cast<uint32_t>(f[c]));
        }
    }
    for (int s = 0; s < ns; ++s) {
      if (needed[s].empty()) continue;
      EnsureOccluderVisibility(s, needed[s]);
      SurfaceState& st = *surfaces_[s];
      const TriangleMesh& mesh = scene_.surface(s).mesh;
      tbb::parallel_for(size_t(0), needed[s].size(), [&](size_t q) {
        const uint32_t v = needed[s][q];
        const Eigen::Vector3f to_camera = center - mesh.vertices[v];
        const float len = to_camera.norm();
        st.view_radiance[v] =
            Shade(light, s, v, len > 0 ? Eigen::Vector3f(to_camera / len) : Eigen::Vector3f(cam_z * -1.0f));
      });
    }
    // Pixels: the mean over the k×k rays of the interpolated vertex radiance (or the background).
    tbb::parallel_for(y0, y1, [&](int y) {
      for (int x = 0; x < width; ++x) {
        const size_t base = (size_t(y - y0) * width + x) * per_pixel;
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        int object_rays = 0;
        for (size_t q = 0; q + 1 < per_pixel; ++q) {
          const RayHit& hit = hits[base + q];
          if (hit.hit) {
            const int s = static_cast<int>(hit.geom_id);
            const Eigen::Vector3i& f = scene_.surface(s).mesh.faces[hit.prim_id];
            const auto& rad = surfaces_[s]->view_radiance;
            sum += (1 - hit.u - hit.v) * rad[f[0]] + hit.u * rad[f[1]] + hit.v * rad[f[2]];
            if (scene_.surface(s).role == SurfaceRole::kObject) ++object_rays;
          } else if (o.background) {
            sum += lighting.Background(rays[base + q].dir.cast<double>()).cast<float>();
          }
        }
        sum /= static_cast<float>(k * k);
        for (int c = 0; c < 3; ++c) out.radiance.at(x, y, c) = sum[c];
        out.coverage.at(x, y) = static_cast<float>(object_rays) / (k * k);
        const RayHit& centre = hits[base + per_pixel - 1];
        const bool object = centre.hit && scene_.surface(int(centre.geom_id)).role == SurfaceRole::kObject;
        out.mask.at(x, y) = object ? 1.0f : 0.0f;
        out.surface.at(x, y) = centre.hit ? static_cast<float>(centre.geom_id) : -1.0f;
        out.depth.at(x, y) = centre.hit ? (centre.point - center).dot(cam_z) : 0.0f;
      }
    });
    if (progress != nullptr) progress->Advance();
  }
  out.seconds = timer.Seconds();
  return out;
}

}  // namespace relight
