// Points uniform over the area of a triangle mesh, for surface-to-surface
// distances (Chamfer, accuracy / completeness) and synthetic point clouds: a
// face is drawn with probability proportional to its area (inverse CDF over
// the cumulative areas), then a uniform point of that triangle by folding a
// uniform point of the unit square (Turk, "Generating Random Points in
// Triangles", Graphics Gems, 1990).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "geometry/mesh.h"

namespace relight {

// `count` points uniform over the surface area of `mesh` (deterministic for a
// seed). Interpolated in float, the precision of the mesh's vertices. Throws
// InternalError for a mesh without faces or without area.
std::vector<Eigen::Vector3f> SampleSurface(const TriangleMesh& mesh, size_t count, uint64_t seed);

}  // namespace relight
