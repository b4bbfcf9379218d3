// An indexed triangle mesh with optional per-vertex normals, colours and
// named scalar properties (material weights, albedo, ...), as exchanged
// between stages in PLY files (docs/FORMATS.md).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <utility>
#include <vector>

namespace relight {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;               // world frame
  std::vector<Eigen::Vector3i> faces;                  // counter-clockwise seen from outside
  std::vector<Eigen::Vector3f> normals;                // unit, per vertex; empty when unknown
  std::vector<Eigen::Matrix<uint8_t, 3, 1>> colors;    // per vertex; empty when unknown
  // Named per-vertex scalars in file order (e.g. "albedo_r", "w0").
  std::vector<std::pair<std::string, std::vector<float>>> properties;

  size_t num_vertices() const { return vertices.size(); }
  size_t num_faces() const { return faces.size(); }
  bool empty() const { return vertices.empty() || faces.empty(); }

  // Area- and angle-weighted vertex normals from the faces (Thürmer & Wüthrich).
  void ComputeVertexNormals();
  // Unit geometric normal of a face (zero for degenerate faces).
  Eigen::Vector3f FaceNormal(int face) const;
  double FaceArea(int face) const;
  double SurfaceArea() const;
  Eigen::AlignedBox3f BoundingBox() const;
  // Mean edge length (a scale for ray offsets and tolerances).
  double MeanEdgeLength() const;

  // The property named `name`, or nullptr.
  const std::vector<float>* FindProperty(const std::string& name) const;
  // Returns the property (created zero-filled when missing).
  std::vector<float>& Property(const std::string& name);
  // Appends another mesh (faces re-indexed); properties missing on either side are zero-filled.
  void Append(const TriangleMesh& other);
  // Throws UserError naming `where` when indices are out of range or sizes disagree.
  void Check(const std::string& where) const;
};

}  // namespace relight
