// Poisson surface reconstruction with CGAL (Kazhdan, Bolitho & Hoppe,
// "Poisson Surface Reconstruction", SGP 2006; CGAL's implementation solves on
// a refined 3D Delaunay triangulation and contours with the surface mesher of
// Boissonnat & Oudot 2005), the alternative to `colmap poisson_mesher`.
#pragma once

#include "geometry/mesh.h"

namespace relight {

// What the reconstruction did.
struct CgalPoissonStats {
  double average_spacing = 0;  // mean distance to the 6 nearest points
  size_t num_points = 0;       // oriented points used
  double seconds = 0;
};

// Surface of oriented points (`points.vertices` with unit `points.normals`, faces ignored). Triangles are
// at most 30 average spacings wide and within 0.375 spacings of the implicit surface (CGAL's defaults).
// Throws UserError when there are too few points or the reconstruction fails.
TriangleMesh CgalPoissonReconstruct(const TriangleMesh& points, CgalPoissonStats* stats = nullptr);

}  // namespace relight
