#include "geometry/mesh.h"

#include <cmath>

#include "core/error.h"

namespace relight {

void TriangleMesh::ComputeVertexNormals() {
  std::vector<Eigen::Vector3d> acc(vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& f : faces) {
    const Eigen::Vector3d p[3] = {vertices[f[0]].cast<double>(), vertices[f[1]].cast<double>(),
                                  vertices[f[2]].cast<double>()};
    const Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double len = n.norm();
    if (len <= 0) continue;
    const Eigen::Vector3d nu = n / len;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
      const double denom = e1.norm() * e2.norm();
      if (denom <= 0) continue;
      const double angle = std::acos(std::clamp(e1.dot(e2) / denom, -1.0, 1.0));
      acc[f[k]] += angle * nu;
    }
  }
  normals.resize(vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) {
    const double len = acc[i].norm();
    normals[i] = len > 0 ? Eigen::Vector3f((acc[i] / len).cast<float>()) : Eigen::Vector3f::UnitZ();
  }
}

Eigen::Vector3f TriangleMesh::FaceNormal(int face) const {
  const auto& f = faces[face];
  const Eigen::Vector3f n = (vertices[f[1]] - vertices[f[0]]).cross(vertices[f[2]] - vertices[f[0]]);
  const float len = n.norm();
  return len > 0 ? Eigen::Vector3f(n / len) : Eigen::Vector3f::Zero();
}

double TriangleMesh::FaceArea(int face) const {
  const auto& f = faces[face];
  return 0.5 * (vertices[f[1]] - vertices[f[0]]).cast<double>().cross((vertices[f[2]] - vertices[f[0]]).cast<double>()).norm();
}

double TriangleMesh::SurfaceArea() const {
  double a = 0;
  for (size_t i = 0; i < faces.size(); ++i) a += FaceArea(static_cast<int>(i));
  return a;
}

Eigen::AlignedBox3f TriangleMesh::BoundingBox() const {
  Eigen::AlignedBox3f box;
  for (const auto& v : vertices) box.extend(v);
  return box;
}

double TriangleMesh::MeanEdgeLength() const {
  double sum = 0;
  long n = 0;
  for (const auto& f : faces) {
    for (int k = 0; k < 3; ++k) {
      sum += (vertices[f[(k + 1) % 3]] - vertices[f[k]]).norm();
      ++n;
    }
  }
  return n ? sum / n : 0.0;
}

const std::vector<float>* TriangleMesh::FindProperty(const std::string& name) const {
  for (const auto& [n, values] : properties)
    if (n == name) return &values;
  return nullptr;
}

std::vector<float>& TriangleMesh::Property(const std::string& name) {
  for (auto& [n, values] : properties) {
    if (n == name) {
      values.resize(vertices.size(), 0.0f);
      return values;
    }
  }
  properties.emplace_back(name, std::vector<float>(vertices.size(), 0.0f));
  return properties.back().second;
}

void TriangleMesh::Append(const TriangleMesh& other) {
  const int offset = static_cast<int>(vertices.size());
  const size_t old_count = vertices.size();
  const bool keep_normals = (normals.size() == old_count || old_count == 0) && other.normals.size() == other.vertices.size();
  const bool keep_colors = (colors.size() == old_count || old_count == 0) && other.colors.size() == other.vertices.size();
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& f : other.faces) faces.push_back(f + Eigen::Vector3i::Constant(offset));
  if (keep_normals) {
    normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  } else {
    normals.clear();
  }
  if (keep_colors) {
    colors.insert(colors.end(), other.colors.begin(), other.colors.end());
  } else {
    colors.clear();
  }
  for (auto& [name, values] : properties) {
    values.resize(old_count, 0.0f);
    const std::vector<float>* theirs = other.FindProperty(name);
    if (theirs != nullptr) {
      values.insert(values.end(), theirs->begin(), theirs->end());
    } else {
      values.resize(vertices.size(), 0.0f);
    }
  }
  for (const auto& [name, values] : other.properties) {
    if (FindProperty(name) != nullptr) continue;
    std::vector<float> v(old_count, 0.0f);
    v.insert(v.end(), values.begin(), values.end());
    properties.emplace_back(name, std::move(v));
  }
}

void TriangleMesh::Check(const std::string& where) const {
  const int n = static_cast<int>(vertices.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (faces[i][k] < 0 || faces[i][k] >= n) {
        RELIGHT_USER_ERROR() << where << ": face " << i << " refers to vertex " << faces[i][k] << " of " << n
                             << "; the mesh file is damaged";
      }
    }
  }
  if (!normals.empty() && normals.size() != vertices.size()) {
    RELIGHT_USER_ERROR() << where << ": " << normals.size() << " normals for " << n << " vertices";
  }
  for (const auto& [name, values] : properties) {
    if (values.size() != vertices.size()) {
      RELIGHT_USER_ERROR() << where << ": property '" << name << "' has " << values.size() << " values for " << n
                           << " vertices";
    }
  }
  for (const auto& v : vertices) {
    if (!v.allFinite()) RELIGHT_USER_ERROR() << where << ": a vertex has a non-finite coordinate";
  }
}

}  // namespace relight
