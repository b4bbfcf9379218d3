// Distances from points to a triangle mesh's surface, with the closest point,
// its face and barycentric coordinates, by CGAL's AABB tree (exact closest
// points in double precision). CGAL stays in mesh_distance.cc: its headers
// compile slowly.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "geometry/mesh.h"

namespace relight {

// The nearest surface point of a mesh.
struct ClosestPoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int face = -1;                                          // index into the mesh's faces
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();  // weights of the face's vertices 0, 1, 2
  double distance = 0;                                    // from the query to `point`
};

// Closest-point queries against a fixed mesh (const queries are thread-safe).
// Degenerate (zero-area) faces are left out: such a face is a segment or a
// point on its longest edge, which in a watertight mesh also borders a face
// with area.
class SurfaceIndex {
 public:
  // The mesh must outlive the index and have a face with nonzero area (checked).
  explicit SurfaceIndex(const TriangleMesh& mesh);
  ~SurfaceIndex();
  SurfaceIndex(const SurfaceIndex&) = delete;
  SurfaceIndex& operator=(const SurfaceIndex&) = delete;

  ClosestPoint Query(const Eigen::Vector3d& p) const;
  // Distance of p to the surface (Query(p).distance without the barycentrics).
  double Distance(const Eigen::Vector3d& p) const;
  // Interpolates a per-vertex property at a closest point.
  double Interpolate(const ClosestPoint& c, const std::vector<float>& values) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const TriangleMesh& mesh_;
};

// Distance of each point to the nearest point of the mesh surface (in parallel).
std::vector<double> DistancesToMesh(const std::vector<Eigen::Vector3f>& points, const TriangleMesh& mesh);

}  // namespace relight
