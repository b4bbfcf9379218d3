// The geometry errors the evaluation reports between a recovered mesh and the
// true one: the symmetric Chamfer distance from area-uniform surface samples,
// with accuracy measured near the object only (docs/METRICS.md). Closest
// points (SurfaceIndex, also used for the per-vertex albedo correspondence)
// and the sampler are geometry's: mesh_distance.h, surface_sampling.h.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/mesh_distance.h"  // SurfaceIndex, ClosestPoint

namespace relight {

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
