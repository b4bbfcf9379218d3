// Closing the holes of a reconstructed surface. `colmap poisson_mesher`
// clips the Poisson iso-surface at its bounding box where the points leave a
// side unobserved (the underside of an object on a table), leaving planar
// boundary loops; each loop is triangulated (Liepa, "Filling Holes in
// Meshes", SGP 2003, as CGAL's triangulate_hole implements it) so the stage
// delivers a closed surface.
#pragma once

#include "geometry/mesh.h"

namespace relight {

// What hole filling did.
struct HoleFillingStats {
  int holes_filled = 0;        // boundary loops triangulated
  int holes_failed = 0;        // loops CGAL could not triangulate
  size_t faces_added = 0;
};

// Triangulates every boundary loop of `mesh` in place (vertex normals recomputed when present).
// Throws UserError when the mesh cannot be turned into a polygon mesh (non-manifold beyond repair).
HoleFillingStats FillHoles(TriangleMesh* mesh);

}  // namespace relight
