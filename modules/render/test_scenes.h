// Small closed-form geometry shared by tests and benchmarks (not part of the library).
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "geometry/mesh.h"
#include "geometry/primitives.h"

namespace relight::render_testing {

// Icosphere of `radius` around `center` with `subdivisions` 1:4 splits; normals
// point outwards (or inwards with `inward`), exactly radial at the vertices.
inline TriangleMesh Icosphere(double radius, const Eigen::Vector3d& center, int subdivisions, bool inward = false) {
  const TriangleMesh sphere = MakeIcosphere(subdivisions);
  std::vector<Eigen::Vector3d> v;
  for (const auto& p : sphere.vertices) v.push_back(p.cast<double>());
  const std::vector<Eigen::Vector3i>& f = sphere.faces;
  TriangleMesh mesh;
  for (const auto& p : v) {
    mesh.vertices.push_back((center + radius * p).cast<float>());
    mesh.normals.push_back((inward ? -p : p).cast<float>());
  }
  for (const auto& tri : f) mesh.faces.push_back(inward ? Eigen::Vector3i(tri[0], tri[2], tri[1]) : tri);
  return mesh;
}

// Square in the plane z = `z` spanning [-half, half]^2, normal +Z, `cells` x `cells` quads.
inline TriangleMesh Plane(double half, double z, int cells = 1) {
  TriangleMesh mesh;
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      mesh.vertices.emplace_back(float(-half + 2 * half * i / cells), float(-half + 2 * half * j / cells), float(z));
      mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      const int a = j * (cells + 1) + i, b = a + 1, c = a + cells + 2, d = a + cells + 1;
      mesh.faces.emplace_back(a, b, c);
      mesh.faces.emplace_back(a, c, d);
    }
  return mesh;
}

// A hemispherical bowl: the lower half of a sphere of radius 0.5 around (0, 0, 0.5), seen from inside (normals
// radial, pointing in; front faces inside), `rings` rings of latitude up to the rim at the equator and
// `segments` around.
inline TriangleMesh Bowl(int rings, int segments) {
  const Eigen::Vector3f center(0, 0, 0.5f);
  const float radius = 0.5f;
  TriangleMesh bowl;
  bowl.vertices.push_back(center - Eigen::Vector3f(0, 0, radius));  // the bottom pole
  for (int i = 1; i <= rings; ++i) {
    const float polar = float(M_PI) * (1.0f - 0.5f * i / rings);  // from the bottom (π) to the rim (π/2)
    for (int j = 0; j < segments; ++j) {
      const float az = 2 * float(M_PI) * j / segments;
      bowl.vertices.push_back(center + radius * Eigen::Vector3f(std::sin(polar) * std::cos(az),
                                                                std::sin(polar) * std::sin(az), std::cos(polar)));
    }
  }
  for (const Eigen::Vector3f& p : bowl.vertices) bowl.normals.push_back((center - p).normalized());
  auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) bowl.faces.emplace_back(0, ring(1, j), ring(1, j + 1));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      bowl.faces.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      bowl.faces.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  // Winding with the normals (front faces inside).
  for (Eigen::Vector3i& f : bowl.faces) {
    const Eigen::Vector3f n =
        (bowl.vertices[f[1]] - bowl.vertices[f[0]]).cross(bowl.vertices[f[2]] - bowl.vertices[f[0]]);
    if (n.dot(bowl.normals[f[0]] + bowl.normals[f[1]] + bowl.normals[f[2]]) < 0) std::swap(f[1], f[2]);
  }
  return bowl;
}

// A bumpy height field over [-1,1]^2 with side x side vertices (100,489 for
// side 317): real self-occlusion for the visibility and observation benchmarks.
inline TriangleMesh Terrain(int side) {
  TriangleMesh m;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      const float x = -1 + 2.0f * i / (side - 1), y = -1 + 2.0f * j / (side - 1);
      const float z = 0.15f * std::sin(7 * x) * std::cos(5 * y) + 0.1f * std::sin(13 * x * y);
      m.vertices.emplace_back(x, y, z);
    }
  for (int j = 0; j + 1 < side; ++j)
    for (int i = 0; i + 1 < side; ++i) {
      const int a = j * side + i;
      m.faces.emplace_back(a, a + 1, a + side + 1);
      m.faces.emplace_back(a, a + side + 1, a + side);
    }
  m.ComputeVertexNormals();
  return m;
}

}  // namespace relight::render_testing
