#include "solver/synthetic_problem.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "geometry/primitives.h"
#include "geometry/raycaster.h"
#include "solver/interreflection.h"
#include "solver/lighting.h"
#include "solver/lobe_spec.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"
#include "visibility/bounce.h"
#include "wavelet/haar.h"

namespace relight {
namespace {

// Sky gradient plus (with `lobe`) a sun blob 0.2 rad wide, RGB radiance.
Eigen::Vector3d SkyAndSun(const Eigen::Vector3d& d, const Eigen::Vector3d& sun, bool lobe) {
  const double up = std::max(0.0, d.z());
  Eigen::Vector3d sky = Eigen::Vector3d(0.3, 0.4, 0.6) * (0.3 + 0.7 * up) + Eigen::Vector3d::Constant(0.05);
  if (!lobe) return sky;
  const double a = std::acos(std::clamp(d.dot(sun), -1.0, 1.0));
  sky += Eigen::Vector3d(6.0, 5.5, 4.5) * std::exp(-a * a / (2 * 0.2 * 0.2));
  return sky;
}

// A lat-long sphere grid with ≈ `vertices` vertices, optionally displaced.
TriangleMesh Blob(int vertices, double displacement) {
  const int rings = std::max(8, static_cast<int>(std::sqrt(vertices / 2.0)));
  const int segments = 2 * rings;
  TriangleMesh m;
  m.vertices.emplace_back(0, 0, 1);
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      const double bump = 1.0 + displacement * std::sin(5 * phi) * std::sin(4 * theta);
      m.vertices.emplace_back(bump * std::sin(theta) * std::cos(phi), bump * std::sin(theta) * std::sin(phi),
                              bump * std::cos(theta));
    }
  }
  m.vertices.emplace_back(0, 0, -1);
  const int south = static_cast<int>(m.vertices.size()) - 1;
  auto idx = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) m.faces.emplace_back(0, idx(1, s), idx(1, s + 1));
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      m.faces.emplace_back(idx(r, s), idx(r + 1, s), idx(r + 1, s + 1));
      m.faces.emplace_back(idx(r, s), idx(r + 1, s + 1), idx(r, s + 1));
    }
  for (int s = 0; s < segments; ++s) m.faces.emplace_back(south, idx(rings - 1, s + 1), idx(rings - 1, s));
  return m;
}

}  // namespace

SyntheticProblem MakeSyntheticProblem(const SyntheticProblemOptions& o) {
  SyntheticProblem s;
  TriangleMesh mesh = o.vertices <= 4100 && o.displacement == 0 ? MakeOctasphere(5) : Blob(o.vertices, o.displacement);
  for (auto& v : mesh.vertices) v.z() += 1.05f + static_cast<float>(o.displacement);
  mesh.ComputeVertexNormals();
  const int ground_cells = o.interreflection && o.ground_albedo > 0 ? 64 : 4;
  TriangleMesh ground = MakeGrid(-8, 8, -8, 8, 0, ground_cells, ground_cells);
  if (ground.normals.size() != ground.num_vertices()) ground.ComputeVertexNormals();
  s.problem.mesh = mesh;
  s.problem.occluders = ground;
  // The observations come from this very mesh (with footprint rows, TransportOptions' default).
  s.problem.mesh_source = "ground_truth";
  const size_t nv = mesh.num_vertices();

  // Visibility, every coefficient kept.
  const RayCaster caster({&mesh, &ground});
  VisibilityOptions vo;
  vo.resolution = o.visibility_resolution;
  vo.supersampling = 2;
  const int n = vo.resolution;
  s.problem.visibility.resolution = n;
  s.problem.visibility.supersampling = 2;
  s.problem.visibility.per_vertex.resize(nv);
  const size_t chunk = 4096;
  for (size_t begin = 0; begin < nv; begin += chunk) {
    const size_t end = std::min(nv, begin + chunk);
    std::vector<uint32_t> ids;
    for (size_t v = begin; v < end; ++v) ids.push_back(static_cast<uint32_t>(v));
    std::vector<float> maps;
    BakeVisibilityMaps(mesh, caster, ids, vo, &maps);
    tbb::parallel_for(size_t(0), ids.size(), [&](size_t q) {
      std::vector<float> c(n * n);
      HaarForward(maps.data() + q * n * n, n, c.data());
      s.problem.visibility.per_vertex[begin + q] = SparseFromDense(c.data(), n);
    });
  }

  // Reflectance: materials blended by smooth position-dependent weights.
  ReflectanceState& r = s.truth.reflectance;
  r.basis = ParseLobeSpecs(o.basis);
  r.num_materials = o.materials;
  const int b_count = r.num_lobes();
  std::mt19937 rng(static_cast<uint32_t>(o.seed));
  std::uniform_real_distribution<double> u(0, 1);
  r.coefficients.assign(size_t(o.materials) * b_count, Eigen::Vector3d::Zero());
  for (int m = 0; m < o.materials; ++m) {
    const Eigen::Vector3d diffuse = m == 0 ? Eigen::Vector3d(0.7, 0.2, 0.15)
                                           : Eigen::Vector3d(0.2 + 0.5 * u(rng), 0.2 + 0.5 * u(rng), 0.2 + 0.5 * u(rng));
    r.coefficients[m * b_count] = diffuse;
    if (o.glossy && b_count > 1 && m > 0) {
      r.coefficients[m * b_count + 1 + (m - 1) % (b_count - 1)] = Eigen::Vector3d::Constant(0.5);
    }
  }
  if (o.materials == 2) r.coefficients[b_count] = Eigen::Vector3d::Constant(0.45);
  if (!o.coefficients.empty()) {
    RELIGHT_CHECK(static_cast<int>(o.coefficients.size()) == o.materials) << "one coefficient list per material";
    for (int m = 0; m < o.materials; ++m) {
      RELIGHT_CHECK(static_cast<int>(o.coefficients[m].size()) == 3 * b_count) << "RGB per lobe";
      for (int b = 0; b < b_count; ++b)
        r.coefficients[m * b_count + b] =
            Eigen::Vector3d(o.coefficients[m][3 * b], o.coefficients[m][3 * b + 1], o.coefficients[m][3 * b + 2]);
    }
  }
  r.weights.assign(nv * o.materials, 0.0f);
  for (size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3f p = mesh.vertices[v];
    if (o.materials == 2) {
      const float w0 = std::clamp(0.5f + p.x() / static_cast<float>(o.blend_width), 0.0f, 1.0f);
      r.weights[v * 2] = w0;
      r.weights[v * 2 + 1] = 1.0f - w0;
      continue;
    }
    // Smooth partition of unity from angular sectors.
    double total = 0;
    std::vector<double> w(o.materials);
    for (int m = 0; m < o.materials; ++m) {
      const double a = 2 * M_PI * m / o.materials;
      const double d = std::cos(std::atan2(p.y(), p.x()) - a) + 0.3 * std::cos(3.0 * p.z() + m);
      total += w[m] = std::exp(4.0 * d);
    }
    for (int m = 0; m < o.materials; ++m) r.weights[v * o.materials + m] = static_cast<float>(w[m] / total);
  }
  s.truth.has_reflectance = true;

  // Photos: distant cameras around the object, one sun each.
  ObservationSet& obs = s.problem.observations;
  obs.num_photos = o.photos;
  obs.num_vertices = static_cast<uint32_t>(nv);
  const int env = o.env_resolution;
  for (int i = 0; i < o.photos; ++i) {
    const double az = 2 * M_PI * i / o.photos;
    const Eigen::Vector3d cam = Eigen::Vector3d(std::cos(az), std::sin(az), 0.3 + 0.4 * (i % 2)).normalized();
    const double sun_az = 0.7 + 1.3 * i, sun_el = 0.3 + 0.15 * (i % 3);
    s.sun_dirs_world.push_back(
        Eigen::Vector3d(std::cos(sun_el) * std::cos(sun_az), std::cos(sun_el) * std::sin(sun_az), std::sin(sun_el)));
    std::vector<float> oct(size_t(env) * env * 3);
    for (int k = 0; k < env * env; ++k) {
      const Eigen::Vector3d d = OctTexelDirection(k % env, k / env, env);
      const Eigen::Vector3d rgb =
          i < o.street_photos ? StreetLight(d) : SkyAndSun(d, s.sun_dirs_world.back(), o.point_sun_irradiance <= 0);
      for (int c = 0; c < 3; ++c) oct[k * 3 + c] = static_cast<float>(rgb[c]);
    }
    if (o.point_sun_irradiance > 0 && i >= o.street_photos) {
      for (const auto& [k, v] : SunSplat(s.sun_dirs_world.back(), env))
        for (int c = 0; c < 3; ++c) oct[k * 3 + c] += static_cast<float>(o.point_sun_irradiance * v);
    }
    s.truth.lighting_oct_rgb.push_back(oct);
    ObservedPhoto p;
    p.index = i;
    p.name = "photo_" + std::to_string(i) + ".jpg";
    s.problem.photos.push_back(p);
    std::vector<uint8_t> seen(nv, 0);
    tbb::parallel_for(size_t(0), nv, [&](size_t v) {
      const Eigen::Vector3d nrm = mesh.normals[v].cast<double>();
      if (nrm.dot(cam) < o.min_view_cos) return;
      const Eigen::Vector3f origin = mesh.vertices[v] + 1e-4f * mesh.normals[v];
      seen[v] = !caster.Occluded({origin, cam.cast<float>()});
    });
    for (size_t v = 0; v < nv; ++v) {
      if (!seen[v]) continue;
      Observation ob;
      ob.photo = i;
      ob.vertex = static_cast<uint32_t>(v);
      ob.confidence = 1.0f;
      const Eigen::Vector3d local = FrameFromNormal<double>(mesh.normals[v].cast<double>()).ToLocal(cam);
      for (int k = 0; k < 3; ++k) ob.view_local[k] = static_cast<float>(local[k]);
      obs.records.push_back(ob);
    }
  }
  s.truth.has_lighting = true;

  // Measurements from the forward model (exact rows).
  TransportOptions to;
  to.basis = r.basis;
  to.env_resolution = env;
  to.keep_energy = o.generation_keep_energy;
  to.max_coefficients = env * env;
  const TransportStore transport = BuildTransport(mesh, s.problem.visibility, obs, to);
  LightingState l;
  l.env_resolution = env;
  l.Resize(o.photos);
  for (int i = 0; i < o.photos; ++i)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < env * env; ++k) l.values[i][c][k] = s.truth.lighting_oct_rgb[i][k * 3 + c];
  l.UpdateCoefficients();
  tbb::parallel_for(size_t(0), obs.records.size(),
                    [&](size_t k) { Predict(transport, obs, k, r, l, obs.records[k].rgb); });
  if (o.interreflection) {
    const bool ground_bounce = o.ground_albedo > 0;
    BounceSamples ground_samples;
    const BounceSamples bounce =
        ComputeBounceSamples(mesh, caster, BounceOptions(), ground_bounce ? &ground_samples : nullptr);
    OccluderBounce from_ground;
    if (ground_bounce) {
      from_ground =
          BuildOccluderBounce(ground, caster, std::move(ground_samples), to, kOccluderBounceVisibilityResolution);
      r.occluder_albedo.setConstant(o.ground_albedo);
    }
    IndirectLight indirect(transport, bounce, obs, ground_bounce ? &from_ground : nullptr);
    indirect.Update(l, r);
    tbb::parallel_for(size_t(0), obs.records.size(), [&](size_t k) {
      Observation& ob = obs.records[k];
      float incoming[3];
      indirect.Indirect(k, incoming);
      std::vector<float> rho(size_t(r.num_lobes()) * 3);
      r.VertexLobeWeights(ob.vertex, rho.data());
      for (int b = 0; b < r.num_lobes(); ++b)
        if (!transport.view_dependent(b))
          for (int c = 0; c < 3; ++c) ob.rgb[c] += rho[b * 3 + c] * incoming[c];
    });
  }
  return s;
}

Eigen::Vector3d StreetLight(const Eigen::Vector3d& d) {
  if (d.z() < -0.2) return Eigen::Vector3d(0.08, 0.07, 0.06);
  if (d.z() > 0 && std::abs(d.y()) < 0.3) return Eigen::Vector3d(0.9, 0.95, 1.0);
  const double azimuth = std::atan2(d.y(), d.x());
  const bool sunlit = static_cast<int>(std::floor(azimuth / (M_PI / 4)) + 8) % 2 == 0;
  return sunlit ? Eigen::Vector3d(0.7, 0.55, 0.4) : Eigen::Vector3d(0.06, 0.07, 0.09);
}

double LightingRelativeError(const SyntheticProblem& s, const LightingState& l, const std::vector<int>& photos) {
  double err = 0, norm = 0;
  for (size_t i = 0; i < s.truth.lighting_oct_rgb.size(); ++i) {
    if (!photos.empty() && std::find(photos.begin(), photos.end(), static_cast<int>(i)) == photos.end()) continue;
    // The truth's grid; SH maps are evaluated on it (their `values` are coefficients).
    const int env = static_cast<int>(std::lround(std::sqrt(s.truth.lighting_oct_rgb[i].size() / 3.0)));
    const std::vector<float> estimate = l.OctahedralRgb(static_cast<int>(i), env);
    for (int c = 0; c < 3; ++c) {
      double ab = 0, bb = 0;
      std::vector<std::pair<double, double>> pairs;
      for (int k = 0; k < env * env; ++k) {
        const Eigen::Vector3d d = OctTexelDirection(k % env, k / env, env);
        if (d.z() < 0.15) continue;  // below: hidden by the ground from every vertex
        const double w = OctTexelSolidAngle(k % env, k / env, env);
        const double t = s.truth.lighting_oct_rgb[i][k * 3 + c], e = estimate[k * 3 + c];
        pairs.emplace_back(t * std::sqrt(w), e * std::sqrt(w));
        ab += t * e * w;
        bb += e * e * w;
      }
      const double scale = bb > 0 ? ab / bb : 1.0;
      for (const auto& [t, e] : pairs) {
        err += (t - scale * e) * (t - scale * e);
        norm += t * t;
      }
    }
  }
  return std::sqrt(err / norm);
}

}  // namespace relight
