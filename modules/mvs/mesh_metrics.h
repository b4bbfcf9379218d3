// Geometry metrics of dense reconstructions against ground truth:
// accuracy / completeness of point clouds at a distance threshold (Seitz et
// al. 2006, Knapitsch et al. 2017), with points-to-points distances by CGAL's
// k-d tree, and the edge topology that says whether a mesh is closed. The
// Chamfer distances are evaluate's (surface_distance.h, mvs_evaluation.h).
// Surface sampling and point-to-mesh distances are geometry's
// (surface_sampling.h, mesh_distance.h), included here for mvs code.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/mesh_distance.h"     // DistancesToMesh
#include "geometry/surface_sampling.h"  // SampleSurface

namespace relight {

// Edge statistics of a triangle mesh.
struct MeshTopology {
  size_t num_edges = 0;
  size_t boundary_edges = 0;      // edges of one triangle
  size_t nonmanifold_edges = 0;   // edges of three or more triangles
  // Every edge is shared by exactly two triangles.
  bool closed() const { return num_edges > 0 && boundary_edges == 0 && nonmanifold_edges == 0; }
};
MeshTopology AnalyzeTopology(const TriangleMesh& mesh);

// Distance of each query to the nearest of `points`.
std::vector<double> DistancesToPoints(const std::vector<Eigen::Vector3f>& queries,
                                      const std::vector<Eigen::Vector3f>& points);
// Fraction of `distances` at most `threshold`.
double FractionWithin(const std::vector<double>& distances, double threshold);

}  // namespace relight
