#include "solver/interreflection.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "core/error.h"
#include "visibility/visibility.h"

namespace relight {

OccluderBounce BuildOccluderBounce(const TriangleMesh& occluders, const RayCaster& caster, BounceSamples samples,
                                   TransportOptions transport, int visibility_resolution) {
  OccluderBounce out;
  // The occluder vertices some sample reaches, renumbered densely.
  std::vector<uint32_t> compact(occluders.num_vertices(), UINT32_MAX);
  for (uint32_t& h : samples.hit_vertex) {
    if (compact[h] == UINT32_MAX) {
      compact[h] = uint32_t(out.vertices.size());
      out.vertices.push_back(h);
    }
    h = compact[h];
  }
  out.samples = std::move(samples);
  if (out.vertices.empty()) return out;
  // Their visibility against the whole scene, as a mesh of lone vertices (rows need no neighbours here).
  VisibilityOptions vo;
  vo.resolution = visibility_resolution;
  vo.supersampling = 2;
  vo.keep_energy = 1.0;
  std::vector<float> maps;
  BakeVisibilityMaps(occluders, caster, out.vertices, vo, &maps);
  VisibilityData visibility;
  visibility.resolution = vo.resolution;
  visibility.supersampling = vo.supersampling;
  visibility.per_vertex = CompressVisibilityMaps(maps, out.vertices.size(), vo);
  TriangleMesh points;
  for (uint32_t h : out.vertices) {
    points.vertices.push_back(occluders.vertices[h]);
    points.normals.push_back(occluders.normals[h]);
  }
  ObservationSet none;
  none.num_vertices = uint32_t(out.vertices.size());
  transport.basis = {BrdfLobe()};  // Lambertian
  transport.footprint_scale = 0;
  transport.spill_dir.clear();
  out.rows = BuildTransport(points, visibility, none, transport);
  return out;
}

IndirectLight::IndirectLight(const TransportStore& transport, const BounceSamples& bounce,
                             const ObservationSet& observations, const OccluderBounce* occluders)
    : transport_(transport), bounce_(bounce), observations_(observations), occluders_(occluders) {
  RELIGHT_CHECK_EQ(bounce.num_vertices(), size_t(observations.num_vertices)) << "bounce samples of another mesh";
  for (int b = 0; b < transport.num_lobes(); ++b)
    if (!transport.view_dependent(b)) lambertian_.push_back(b);
}

void IndirectLight::Update(const LightingState& lighting, const ReflectanceState& reflectance) {
  const size_t nv = bounce_.num_vertices(), num_photos = lighting.coefficients.size();
  const int num_lobes = reflectance.num_lobes();
  RELIGHT_CHECK_EQ(num_lobes, transport_.num_lobes()) << "reflectance and transport of different bases";
  exit_.resize(num_photos);
  for (std::vector<float>& exit : exit_) exit.assign(nv * 3, 0.0f);
  if (lambertian_.empty()) return;
  if (has_occluders()) {
    occluder_albedo_ = reflectance.occluder_albedo.cast<float>();
    const size_t nk = occluders_->vertices.size();
    occluder_exit_.resize(num_photos);
    for (std::vector<float>& exit : occluder_exit_) exit.assign(nk * 3, 0.0f);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nk, 256), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) {
        const TransportStore::Row row = occluders_->rows.Get(0, uint32_t(k), 0);
        for (size_t i = 0; i < num_photos; ++i)
          for (int c = 0; c < 3; ++c) {
            const float* light = lighting.coefficients[i][c].data();
            float sum = 0.0f;
            for (uint32_t q = 0; q < row.size; ++q) sum += row.value[q] * light[row.index[q]];
            occluder_exit_[i][k * 3 + c] = sum;
          }
      }
    });
  }
  // Vertex-major: each vertex's row is read once for every photo.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 256), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<float> rho(size_t(num_lobes) * 3);
    for (size_t v = r.begin(); v < r.end(); ++v) {
      reflectance.VertexLobeWeights(uint32_t(v), rho.data());
      for (int b : lambertian_) {
        if (rho[b * 3] == 0.0f && rho[b * 3 + 1] == 0.0f && rho[b * 3 + 2] == 0.0f) continue;
        const TransportStore::Row row = transport_.Get(0, uint32_t(v), b);
        for (size_t i = 0; i < num_photos; ++i) {
          for (int c = 0; c < 3; ++c) {
            const float* light = lighting.coefficients[i][c].data();
            float sum = 0.0f;
            for (uint32_t k = 0; k < row.size; ++k) sum += row.value[k] * light[row.index[k]];
            exit_[i][v * 3 + c] += rho[b * 3 + c] * sum;
          }
        }
      }
    }
  });
}

void IndirectLight::Indirect(size_t observation, float out[3]) const {
  const Observation& ob = observations_.records[observation];
  RELIGHT_CHECK_LT(size_t(ob.photo), exit_.size()) << "IndirectLight::Update was not called";
  const float* exit = exit_[ob.photo].data();
  for (int c = 0; c < 3; ++c) out[c] = bounce_.Gather(ob.vertex, exit, 3, c);
  if (has_occluders()) {
    float from_occluders[3];
    OccluderGather(observation, from_occluders);
    for (int c = 0; c < 3; ++c) out[c] += occluder_albedo_[c] * from_occluders[c];
  }
}

void IndirectLight::OccluderGather(size_t observation, float out[3]) const {
  const Observation& ob = observations_.records[observation];
  const float* exit = occluder_exit_[ob.photo].data();
  for (int c = 0; c < 3; ++c) out[c] = occluders_->samples.Gather(ob.vertex, exit, 3, c);
}

Eigen::Vector3d IndirectLight::FitOccluderAlbedo(const std::vector<uint32_t>& ids, const std::vector<float>& responses,
                                                 const ReflectanceState& reflectance) const {
  if (!has_occluders()) return reflectance.occluder_albedo;
  const int num_lobes = transport_.num_lobes();
  RELIGHT_CHECK_EQ(responses.size(), ids.size() * num_lobes * 3) << "responses of other observations";
  // Residual r = y − ŷ and derivative d = ∂ŷ/∂ρ_occ = (Σ_{b Lambertian} ρ_{v,b}) G_o per channel.
  Eigen::Vector3d num = Eigen::Vector3d::Zero(), den = Eigen::Vector3d::Zero();
  std::vector<float> rho(size_t(num_lobes) * 3);
  for (size_t k = 0; k < ids.size(); ++k) {
    const Observation& ob = observations_.records[ids[k]];
    if (ob.lower_bound()) continue;
    float gather[3];
    OccluderGather(ids[k], gather);
    if (gather[0] == 0.0f && gather[1] == 0.0f && gather[2] == 0.0f) continue;
    reflectance.VertexLobeWeights(ob.vertex, rho.data());
    for (int c = 0; c < 3; ++c) {
      double predicted = 0, lambert = 0;
      for (int b = 0; b < num_lobes; ++b) predicted += rho[b * 3 + c] * responses[(k * num_lobes + b) * 3 + c];
      for (int b : lambertian_) lambert += rho[b * 3 + c];
      const double d = lambert * gather[c];
      num[c] += ob.confidence * (ob.rgb[c] - predicted) * d;
      den[c] += ob.confidence * d * d;
    }
  }
  Eigen::Vector3d albedo = reflectance.occluder_albedo;
  for (int c = 0; c < 3; ++c)
    if (den[c] > 0) albedo[c] = std::max(0.0, albedo[c] + num[c] / den[c]);
  return albedo;
}

void IndirectLight::AddToResponses(const std::vector<uint32_t>& ids, float sign, std::vector<float>* responses) const {
  const int num_lobes = transport_.num_lobes();
  RELIGHT_CHECK_EQ(responses->size(), ids.size() * num_lobes * 3) << "responses of other observations";
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k < r.end(); ++k) {
      float indirect[3];
      Indirect(ids[k], indirect);
      float* out = responses->data() + k * num_lobes * 3;
      for (int b : lambertian_)
        for (int c = 0; c < 3; ++c) out[b * 3 + c] += sign * indirect[c];
    }
  });
}

ObservationSet IndirectLight::DirectTargets(const ReflectanceState& reflectance) const {
  ObservationSet targets = observations_;
  const int num_lobes = reflectance.num_lobes();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, targets.records.size(), 1024),
                    [&](const tbb::blocked_range<size_t>& r) {
                      std::vector<float> rho(size_t(num_lobes) * 3);
                      for (size_t o = r.begin(); o < r.end(); ++o) {
                        Observation& ob = targets.records[o];
                        float indirect[3];
                        Indirect(o, indirect);
                        reflectance.VertexLobeWeights(ob.vertex, rho.data());
                        for (int b : lambertian_)
                          for (int c = 0; c < 3; ++c) ob.rgb[c] -= rho[b * 3 + c] * indirect[c];
                      }
                    });
  return targets;
}

double IndirectLight::IndirectShare(const std::vector<uint32_t>& ids, const std::vector<float>& responses) const {
  const int num_lobes = transport_.num_lobes();
  double indirect_sum = 0, total_sum = 0;
  for (size_t k = 0; k < ids.size(); ++k) {
    float indirect[3];
    Indirect(ids[k], indirect);
    for (int b : lambertian_)
      for (int c = 0; c < 3; ++c) {
        indirect_sum += indirect[c];
        total_sum += responses[(k * num_lobes + b) * 3 + c];
      }
  }
  return total_sum > 0 ? indirect_sum / total_sum : 0.0;
}

}  // namespace relight
