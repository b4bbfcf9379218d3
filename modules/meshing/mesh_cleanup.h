// Mesh clean-up with CGAL 5.5 (Polygon_mesh_processing and
// Surface_mesh_simplification): from a noisy, possibly non-manifold triangle
// soup (a Poisson surface with floating fragments, a scan with holes) to
// oriented 2-manifold components with a vertex budget.
//
// Steps, each a CGAL function: polygon-soup repair (merge duplicate points,
// drop degenerate and duplicate polygons) and orientation (non-manifold edges
// and vertices are split by duplicating points) → Surface_mesh; degenerate
// faces; non-manifold vertices; connected components by area; small holes
// (triangulate, refine, fair); edge-collapse decimation and isotropic
// remeshing to the target vertex count; outward orientation of closed
// components. All CGAL code of the project lives in mesh_cleanup.cc (compile time).
// Before remeshing, what hole filling may have broken is repaired: faces on
// non-finite points, degenerate faces, non-manifold vertices, and both faces
// of each self-intersecting pair are removed (CGAL's isotropic remeshing
// crashes on such input); a mesh that still is not valid is only decimated.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "geometry/mesh.h"

namespace relight {

// Clean-up parameters (the mesh stage fills them from MeshOptions).
struct MeshCleanupOptions {
  int target_vertices = 50000;           // 0: keep the resolution
  bool remesh = true;                    // isotropic remeshing (else edge-collapse decimation only)
  int max_components = 1;                // best supported (else largest by area) first
  double min_component_fraction = 0.05;  // of the best component's support (else area)
  // Data points that rank the components (the fused MVS cloud; not owned). A
  // component's support is the number of points whose nearest vertex within
  // `support_radius` is its. A watertight Poisson surface of an object on
  // the ground, cropped, leaves the ground's top and its spurious underside as
  // separate sheets; the underside can have the larger area but carries no
  // data. nullptr or no point near any vertex: components rank by area.
  const std::vector<Eigen::Vector3d>* support_points = nullptr;
  double support_radius = 0;  // mesh units
  int max_hole_edges = 500;              // holes with more boundary edges stay open
  double max_hole_fraction = 0.1;        // holes wider than this fraction of the bbox diagonal stay open
  int remesh_iterations = 3;             // per remeshing pass
  double vertex_tolerance = 0.05;        // remeshing passes stop within this relative error of the target
};

// What the clean-up did.
struct MeshCleanupSummary {
  size_t input_vertices = 0;
  size_t input_faces = 0;
  size_t duplicate_points_merged = 0;         // soup points merged into others
  size_t soup_polygons_removed = 0;           // degenerate / duplicate polygons
  size_t non_manifold_points_duplicated = 0;  // points split to make edges and vertices manifold
  size_t degenerate_faces_removed = 0;
  size_t invalid_faces_removed = 0;            // on non-finite or out-of-range vertices
  size_t self_intersecting_faces_removed = 0;  // before remeshing
  int components_found = 0;
  std::string component_ranking = "area";  // "support" (data points) or "area"
  int components_removed = 0;
  size_t faces_removed_with_components = 0;
  int holes_filled = 0;
  int holes_left = 0;  // boundary cycles left open (too large, or the crop border)
  size_t hole_faces_added = 0;
  double target_edge_length = 0;  // remeshing edge length (mesh units), 0 when not remeshed
  int resample_passes = 0;
  std::string remesh_skipped;  // why isotropic remeshing was replaced by decimation ("" when it ran)
  bool closed = false;                // every kept component is closed
  bool orientation_reversed = false;  // closed mesh whose faces pointed inward
  size_t output_vertices = 0;
  size_t output_faces = 0;
  std::vector<std::pair<std::string, double>> step_seconds;
};

// Cleans `input` (faces only; named vertex properties are not carried: the
// vertices are new). Throws UserError naming `where` when nothing is left.
// Normals of the result are computed from its faces.
TriangleMesh CleanMesh(const TriangleMesh& input, const MeshCleanupOptions& options, const std::string& where,
                       MeshCleanupSummary* summary);

// 2-manifold checks used by tests and the stage's final verification:
// every edge has one or two faces, consistently oriented, and the faces
// around every vertex form a single fan. Returns "" when manifold, else the
// first violation found.
std::string FindManifoldViolation(const TriangleMesh& mesh);

// Number of boundary edges (edges with one face).
size_t CountBoundaryEdges(const TriangleMesh& mesh);

// Number of connected components (faces connected through shared edges).
int CountComponents(const TriangleMesh& mesh);

}  // namespace relight
