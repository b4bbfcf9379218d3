#include "evaluate/surface_distance.h"

#include <Eigen/Geometry>
#include <utility>

#include "core/stats.h"
#include "evaluate/image_metrics.h"
#include "geometry/surface_sampling.h"

namespace relight {
namespace {

// The faces of `a` and `b` as one mesh (no vertex properties): its distance is the nearer of the two.
TriangleMesh Surfaces(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh out;
  out.vertices = a.vertices;
  out.faces = a.faces;
  out.vertices.insert(out.vertices.end(), b.vertices.begin(), b.vertices.end());
  const Eigen::Vector3i offset = Eigen::Vector3i::Constant(static_cast<int>(a.vertices.size()));
  for (const Eigen::Vector3i& f : b.faces) out.faces.push_back(f + offset);
  return out;
}

}  // namespace

MeshDistances CompareMeshes(const TriangleMesh& estimate, const TriangleMesh& truth, size_t samples, uint64_t seed,
                            const TriangleMesh* truth_context) {
  MeshDistances d;
  d.samples = samples;
  d.diagonal = truth.BoundingBox().diagonal().norm();
  const bool with_context = truth_context != nullptr && truth_context->num_faces() > 0;
  std::vector<Eigen::Vector3f> estimate_points = SampleSurface(estimate, samples, seed);
  if (with_context) {
    // Only the estimate around the object counts; the ground it stands on is true surface too.
    Eigen::AlignedBox3d box = truth.BoundingBox().cast<double>();
    box.min().array() -= 0.1 * d.diagonal;
    box.max().array() += 0.1 * d.diagonal;
    std::vector<Eigen::Vector3f> inside;
    for (const Eigen::Vector3f& p : estimate_points) {
      if (box.contains(p.cast<double>())) inside.push_back(p);
    }
    // An estimate with no surface around the object (a mesh stage that kept the
    // wrong part) is scored whole: far from everything, not undefined.
    d.estimate_samples_near_object = inside.size();
    if (!inside.empty()) estimate_points = std::move(inside);
  } else {
    d.estimate_samples_near_object = estimate_points.size();
  }
  std::vector<double> acc = with_context ? DistancesToMesh(estimate_points, Surfaces(truth, *truth_context))
                                         : DistancesToMesh(estimate_points, truth);
  std::vector<double> comp = DistancesToMesh(SampleSurface(truth, samples, seed + 1), estimate);
  d.accuracy_mean = Mean(acc);
  d.completeness_mean = Mean(comp);
  d.chamfer = 0.5 * (d.accuracy_mean + d.completeness_mean);
  d.accuracy_p90 = Percentile(&acc, 90);
  d.completeness_p90 = Percentile(&comp, 90);
  return d;
}

}  // namespace relight
