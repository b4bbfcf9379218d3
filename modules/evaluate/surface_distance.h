// Closest points on a triangle mesh (CGAL AABB tree) and the geometry errors
// the evaluation reports: per-vertex correspondence between a recovered mesh
// and the true one (to compare albedo on different meshes) and the symmetric
// Chamfer distance from area-uniform surface samples (docs/METRICS.md).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "geometry/mesh.h"

namespace relight {

// The nearest surface point of a mesh.
struct ClosestPoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();  // weights of the face's vertices 0, 1, 2
  double distance = 0;
};

// Closest-point queries against a fixed mesh (thread-safe after construction).
class SurfaceIndex {
 public:
  // The mesh must outlive the index and have at least one face.
  explicit SurfaceIndex(const TriangleMesh& mesh);
  ~SurfaceIndex();
  SurfaceIndex(const SurfaceIndex&) = delete;
  SurfaceIndex& operator=(const SurfaceIndex&) = delete;
  ClosestPoint Query(const Eigen::Vector3d& p) const;
  // Interpolates a per-vertex property at a closest point.
  double Interpolate(const ClosestPoint& c, const std::vector<float>& values) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const TriangleMesh& mesh_;
};

// `count` points uniform over the surface area (deterministic for a seed).
std::vector<Eigen::Vector3d> SampleSurfaceUniform(const TriangleMesh& mesh, size_t count, uint64_t seed);

// Distances between two surfaces in one frame.
struct MeshDistances {
  double diagonal = 0;           // bounding-box diagonal of the true mesh (the unit of the relative numbers)
  double accuracy_mean = 0;      // mean distance of estimate samples to the true surface
  double completeness_mean = 0;  // mean distance of true samples to the estimate
  double chamfer = 0;            // (accuracy_mean + completeness_mean) / 2
  double accuracy_p90 = 0;       // 90th percentile of the estimate->truth distances
  double completeness_p90 = 0;
  size_t samples = 0;  // per mesh
  size_t estimate_samples_near_object = 0;  // estimate samples in the accuracy region (see below)
};
// With `truth_context` (the true ground and blockers around the object), accuracy
// uses only the estimate's samples inside the object's bounding box grown by 10%
// of its diagonal, scored against the nearest true surface (object or context):
// a reconstruction may rightly include the ground the object stands on. When
// none lies there, all the estimate's samples count.
// Completeness is always the object's samples against the estimate.
MeshDistances CompareMeshes(const TriangleMesh& estimate, const TriangleMesh& truth, size_t samples, uint64_t seed = 1,
                            const TriangleMesh* truth_context = nullptr);

}  // namespace relight
