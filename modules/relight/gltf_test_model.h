// The model the glTF export tests write (not part of the library): an icosphere with four materials over
// Lambertian, Phong (n = 50) and GGX (alpha = 0.2) lobes, per-vertex weights that make three of them dominant
// somewhere and one nowhere, and a per-vertex albedo in [0, 1] except one vertex at 1.5 (clamped).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "brdf/brdf.h"
#include "geometry/mesh.h"
#include "render/test_scenes.h"

namespace relight::gltf_testing {

struct TestModel {
  TriangleMesh mesh;
  ReflectanceModel reflectance;
};

inline TestModel MakeTestModel() {
  TestModel t;
  const Eigen::Vector3d center(0.1, -0.3, 0.6);
  t.mesh = render_testing::Icosphere(0.5, center, 2);
  const BrdfLobe lambert{};
  const BrdfLobe phong{BrdfModel::kPhong, 0.3, 0.04, 50};
  const BrdfLobe ggx{BrdfModel::kGgx, 0.2, 0.04, 50};
  t.reflectance.basis = {lambert, phong, ggx};
  t.reflectance.materials = {{"terracotta", {{0.7, 0.3, 0.2}, {0, 0, 0}, {0, 0, 0}}},
                             {"glaze", {{0.1, 0.2, 0.5}, {0.3, 0.3, 0.3}, {0, 0, 0}}},
                             {"ivory", {{0.8, 0.8, 0.7}, {0.1, 0.1, 0.1}, {0.5, 0.5, 0.5}}},
                             {"unused", {{0.5, 0.5, 0.5}, {0, 0, 0}, {0.2, 0.2, 0.2}}}};
  const size_t n = t.mesh.num_vertices();
  std::vector<float>* w[4];
  for (int m = 0; m < 4; ++m) w[m] = &t.mesh.Property("w" + std::to_string(m));
  std::vector<float>&ar = t.mesh.Property("albedo_r"), &ag = t.mesh.Property("albedo_g"),
  &ab = t.mesh.Property("albedo_b");
  for (size_t v = 0; v < n; ++v) {
    const Eigen::Vector3d d = (t.mesh.vertices[v].cast<double>() - center).normalized();
    // Material regions: +x, -x and the rest (by |z|); "unused" never reaches the others.
    (*w[0])[v] = float(std::max(0.0, d.x()));
    (*w[1])[v] = float(std::max(0.0, -d.x()));
    (*w[2])[v] = float(0.8 * std::abs(d.z()));
    (*w[3])[v] = 0.05f;
    ar[v] = float(0.5 + 0.45 * d.x());
    ag[v] = float(0.5 + 0.45 * d.y());
    ab[v] = float(0.25 + 0.2 * d.z());
  }
  ar[7] = 1.5f;  // above 1 (one vertex: below the export gauge's percentile): clamped to 1
  return t;
}

}  // namespace relight::gltf_testing
