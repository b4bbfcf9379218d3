#include "synth/materials.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "render/rng.h"
#include "synth/noise.h"

namespace relight {

ReflectanceModel PruneUnusedLobes(const ReflectanceModel& model) {
  ReflectanceModel out;
  out.materials.resize(model.materials.size());
  for (size_t m = 0; m < model.materials.size(); ++m) out.materials[m].name = model.materials[m].name;
  for (size_t b = 0; b < model.basis.size(); ++b) {
    bool used = false;
    for (const auto& m : model.materials) used |= m.coefficients[b].maxCoeff() > 0;
    if (!used) continue;
    out.basis.push_back(model.basis[b]);
    for (size_t m = 0; m < model.materials.size(); ++m)
      out.materials[m].coefficients.push_back(model.materials[m].coefficients[b]);
  }
  return out;
}

ReflectanceModel BuiltinObjectMaterials(int num_materials) {
  if (num_materials < 1 || num_materials > 4) {
    RELIGHT_USER_ERROR() << "num_materials = " << num_materials
                         << ": the built-in set has 1 to 4 materials; give a materials.json for more";
  }
  BrdfLobe lambert, phong50, ggx, phong500;
  phong50.model = BrdfModel::kPhong;
  phong50.exponent = 50;
  ggx.model = BrdfModel::kGgx;
  ggx.roughness = 0.15;
  ggx.f0 = 0.04;
  phong500.model = BrdfModel::kPhong;
  phong500.exponent = 500;
  ReflectanceModel model;
  model.basis = {lambert, phong50, ggx, phong500};
  using V = Eigen::Vector3d;
  const V zero = V::Zero();
  model.materials = {
      {"terracotta", {V(0.62, 0.30, 0.17), zero, zero, zero}},
      {"blue glaze", {V(0.08, 0.16, 0.42), V(0.25, 0.25, 0.25), zero, zero}},
      {"ivory", {V(0.78, 0.74, 0.62), zero, V(1.0, 1.0, 1.0), zero}},
      {"brass", {V(0.05, 0.04, 0.02), zero, zero, V(0.60, 0.45, 0.22)}},
  };
  model.materials.resize(num_materials);
  return PruneUnusedLobes(model);
}

ReflectanceModel BuiltinPrimaryMaterials() {
  using V = Eigen::Vector3d;
  ReflectanceModel model;
  model.basis = {BrdfLobe{}};
  model.materials = {{"red", {V(0.8, 0.0, 0.0)}}, {"green", {V(0.0, 0.8, 0.0)}}, {"blue", {V(0.0, 0.0, 0.8)}}};
  return model;
}

ReflectanceModel BuiltinGroundMaterials() {
  using V = Eigen::Vector3d;
  ReflectanceModel model;
  model.basis = {BrdfLobe{}};
  model.materials = {
      {"pale stone", {V(0.55, 0.52, 0.47)}}, {"dark stone", {V(0.22, 0.21, 0.20)}}, {"sand", {V(0.60, 0.47, 0.32)}}};
  return model;
}

void AssignMaterialWeights(const ReflectanceModel& model, const WeightPattern& pattern, TriangleMesh* mesh) {
  const int num_materials = static_cast<int>(model.materials.size());
  RELIGHT_CHECK_GT(num_materials, 0);
  const size_t n = mesh->num_vertices();
  std::vector<std::vector<float>> w(num_materials, std::vector<float>(n, 0.0f));
  if (pattern.kind == "single" || num_materials == 1) {
    std::fill(w[0].begin(), w[0].end(), 1.0f);
  } else if (pattern.kind == "noise") {
    // One fractal field per material; the weights are their softmax, so regions of one
    // material meet in soft, fractal borders.
    std::vector<GradientNoise> fields;
    for (int m = 0; m < num_materials; ++m) fields.emplace_back(MixSeed(pattern.seed, uint64_t(m)));
    std::vector<double> f(num_materials);
    for (size_t v = 0; v < n; ++v) {
      const Eigen::Vector3d p = mesh->vertices[v].cast<double>() * pattern.frequency;
      double largest = -1e300;
      for (int m = 0; m < num_materials; ++m) {
        f[m] = pattern.sharpness * fields[m].Fractal(p, pattern.octaves);
        largest = std::max(largest, f[m]);
      }
      double sum = 0;
      for (int m = 0; m < num_materials; ++m) sum += f[m] = std::exp(f[m] - largest);
      for (int m = 0; m < num_materials; ++m) w[m][v] = static_cast<float>(f[m] / sum);
    }
  } else if (pattern.kind == "voronoi") {
    // Cells of one material each; the border between the two nearest cells is blended over a
    // width of about 1/sharpness cells.
    for (size_t v = 0; v < n; ++v) {
      const CellSample cell = CellularNoise(mesh->vertices[v].cast<double>() * pattern.frequency, pattern.seed);
      const int m1 = static_cast<int>(cell.id1 % uint64_t(num_materials));
      const int m2 = static_cast<int>(cell.id2 % uint64_t(num_materials));
      const double t = 1.0 / (1.0 + std::exp(-pattern.sharpness * (cell.distance2 - cell.distance1)));
      w[m1][v] += static_cast<float>(t);
      w[m2][v] += static_cast<float>(1 - t);
    }
  } else if (pattern.kind == "mosaic") {
    // Per-vertex colours for a model of three primaries (red, green, blue): a random
    // colour per Voronoi cell (crisp edges and corners) modulated by coloured
    // fractal noise (detail at every scale) -- distinctive, non-repeating texture
    // that structure from motion matches reliably, unlike the few-material patterns.
    if (num_materials != 3) {
      RELIGHT_USER_ERROR() << "weight pattern 'mosaic' needs exactly three materials (primaries), got "
                           << num_materials;
    }
    std::vector<GradientNoise> fields;
    for (int m = 0; m < 3; ++m) fields.emplace_back(MixSeed(pattern.seed, uint64_t(100 + m)));
    for (size_t v = 0; v < n; ++v) {
      const Eigen::Vector3d p = mesh->vertices[v].cast<double>() * pattern.frequency;
      const CellSample cell = CellularNoise(p, pattern.seed);
      for (int m = 0; m < 3; ++m) {
        const uint64_t h = MixSeed(cell.id1, uint64_t(m));
        const double cell_colour = double(h % 1000003) / 1000003.0;
        const double detail = fields[m].Fractal(p * 4.0, pattern.octaves);
        w[m][v] = static_cast<float>(std::clamp(0.1 + 0.75 * cell_colour + 0.25 * detail, 0.02, 1.0));
      }
    }
  } else {
    RELIGHT_USER_ERROR() << "unknown weight pattern '" << pattern.kind << "'; allowed: noise, voronoi, mosaic, single";
  }
  for (int m = 0; m < num_materials; ++m) mesh->Property("w" + std::to_string(m)) = std::move(w[m]);
  // Remove stale weights of a previous, larger model.
  for (int m = num_materials;; ++m) {
    const std::string name = "w" + std::to_string(m);
    auto it =
        std::find_if(mesh->properties.begin(), mesh->properties.end(), [&](const auto& p) { return p.first == name; });
    if (it == mesh->properties.end()) break;
    mesh->properties.erase(it);
  }
  std::vector<float> albedo[3];
  for (auto& a : albedo) a.resize(n);
  std::vector<const std::vector<float>*> columns;
  for (int m = 0; m < num_materials; ++m) columns.push_back(mesh->FindProperty("w" + std::to_string(m)));
  std::vector<double> weights(num_materials);
  for (size_t v = 0; v < n; ++v) {
    for (int m = 0; m < num_materials; ++m) weights[m] = (*columns[m])[v];
    const Eigen::Vector3d a = model.DiffuseAlbedo(weights);
    for (int c = 0; c < 3; ++c) albedo[c][v] = static_cast<float>(a[c]);
  }
  mesh->Property("albedo_r") = std::move(albedo[0]);
  mesh->Property("albedo_g") = std::move(albedo[1]);
  mesh->Property("albedo_b") = std::move(albedo[2]);
}

}  // namespace relight
