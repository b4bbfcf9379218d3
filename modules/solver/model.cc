#include "solver/model.h"

#include <algorithm>

#include "core/error.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "wavelet/haar.h"

namespace relight {

void ReflectanceState::VertexLobeWeights(uint32_t v, float* out) const {
  const int b_count = num_lobes();
  for (int k = 0; k < b_count * 3; ++k) out[k] = 0.0f;
  const float* w = weights.data() + size_t(v) * num_materials;
  for (int m = 0; m < num_materials; ++m) {
    if (w[m] == 0.0f) continue;
    for (int b = 0; b < b_count; ++b) {
      const Eigen::Vector3d& c = coefficients[m * b_count + b];
      for (int ch = 0; ch < 3; ++ch) out[b * 3 + ch] += w[m] * static_cast<float>(c[ch]);
    }
  }
}

ReflectanceModel ReflectanceState::Model() const {
  ReflectanceModel model;
  model.basis = basis;
  for (int m = 0; m < num_materials; ++m) {
    Material mat;
    mat.name = "material " + std::to_string(m);
    for (int b = 0; b < num_lobes(); ++b) mat.coefficients.push_back(coefficients[m * num_lobes() + b]);
    model.materials.push_back(mat);
  }
  return model;
}

void LightingState::Resize(int num_photos) {
  dim = basis == "haar" ? env_resolution * env_resolution : ShNumCoefficients(sh_order);
  values.assign(num_photos, {});
  coefficients.assign(num_photos, {});
  sun_dir_world.assign(num_photos, Eigen::Vector3d::UnitZ());
  sun_irradiance.assign(num_photos, Eigen::Vector3d::Zero());
  for (int i = 0; i < num_photos; ++i)
    for (int c = 0; c < 3; ++c) {
      values[i][c].assign(dim, 0.0f);
      coefficients[i][c].assign(dim, 0.0f);
    }
}

void LightingState::UpdateCoefficients() {
  for (size_t i = 0; i < values.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (basis == "haar") {
        HaarForward(values[i][c].data(), env_resolution, coefficients[i][c].data());
      } else {
        coefficients[i][c] = values[i][c];
      }
    }
  }
}

void LightingState::ScaleChannels(const Eigen::Vector3d& s) {
  for (auto& photo : values)
    for (int c = 0; c < 3; ++c)
      for (float& v : photo[c]) v = static_cast<float>(v * s[c]);
  for (Eigen::Vector3d& e : sun_irradiance) e = e.cwiseProduct(s);
  UpdateCoefficients();
}

void LightingState::ExtrapolateFrom(const LightingState& prev, double step) {
  for (size_t i = 0; i < values.size(); ++i)
    for (int c = 0; c < 3; ++c)
      for (size_t k = 0; k < values[i][c].size(); ++k) {
        const float p = prev.values[i][c][k];
        float v = static_cast<float>(p + step * (values[i][c][k] - p));
        if (basis == "haar") v = std::max(0.0f, v);
        values[i][c][k] = v;
      }
  for (size_t i = 0; i < sun_irradiance.size() && i < prev.sun_irradiance.size(); ++i) {
    if (!has_sun(i) || !prev.has_sun(i) || sun_dir_world[i] != prev.sun_dir_world[i]) continue;
    sun_irradiance[i] = (prev.sun_irradiance[i] + step * (sun_irradiance[i] - prev.sun_irradiance[i])).cwiseMax(0.0);
  }
  UpdateCoefficients();
}

std::vector<float> LightingState::OctahedralRgb(int photo, int n) const {
  std::vector<float> rgb(size_t(n) * n * 3, 0.0f);
  if (basis == "haar") {
    RELIGHT_CHECK_EQ(n, env_resolution);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < n * n; ++k) rgb[k * 3 + c] = values[photo][c][k];
    return rgb;
  }
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXf>(values[photo][c].data(), dim).cast<double>();
    const std::vector<float> oct = ShToOct(x, n);
    for (int k = 0; k < n * n; ++k) rgb[k * 3 + c] = oct[k];
  }
  return rgb;
}

void LobePredictions(const TransportStore& transport, const ObservationSet& obs, size_t o, const LightingState& l,
                     float* out) {
  const Observation& ob = obs.records[o];
  for (int b = 0; b < transport.num_lobes(); ++b) {
    for (int c = 0; c < 3; ++c) {
      out[b * 3 + c] = transport.Dot(o, ob.vertex, b, l.coefficients[ob.photo][c].data());
    }
  }
}

void Predict(const TransportStore& transport, const ObservationSet& obs, size_t o, const ReflectanceState& r,
             const LightingState& l, float out[3]) {
  const Observation& ob = obs.records[o];
  float rho[64 * 3];
  RELIGHT_CHECK_LE(r.num_lobes(), 64);
  r.VertexLobeWeights(ob.vertex, rho);
  out[0] = out[1] = out[2] = 0.0f;
  for (int b = 0; b < transport.num_lobes(); ++b) {
    const TransportStore::Row row = transport.Get(o, ob.vertex, b);
    for (int c = 0; c < 3; ++c) {
      if (rho[b * 3 + c] == 0.0f) continue;
      const float* lc = l.coefficients[ob.photo][c].data();
      float s = 0.0f;
      for (uint32_t k = 0; k < row.size; ++k) s += row.value[k] * lc[row.index[k]];
      out[c] += rho[b * 3 + c] * s;
    }
  }
}

}  // namespace relight
