#include "mvs/hole_filling.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <iterator>
#include <vector>

#include "core/error.h"

namespace relight {

HoleFillingStats FillHoles(TriangleMesh* mesh) {
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Point = Kernel::Point_3;
  using SurfaceMesh = CGAL::Surface_mesh<Point>;
  namespace PMP = CGAL::Polygon_mesh_processing;
  HoleFillingStats stats;
  std::vector<Point> points;
  points.reserve(mesh->vertices.size());
  for (const auto& v : mesh->vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::array<size_t, 3>> polygons;
  polygons.reserve(mesh->faces.size());
  for (const auto& f : mesh->faces) polygons.push_back({size_t(f[0]), size_t(f[1]), size_t(f[2])});
  // Duplicates vertices at non-manifold configurations so the soup becomes a valid halfedge mesh.
  PMP::orient_polygon_soup(points, polygons);
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  if (!sm.is_valid(false)) RELIGHT_USER_ERROR() << "the Poisson surface is not a valid polygon mesh; cannot fill holes";

  std::vector<SurfaceMesh::Halfedge_index> borders;
  PMP::extract_boundary_cycles(sm, std::back_inserter(borders));
  for (const auto h : borders) {
    std::vector<SurfaceMesh::Face_index> new_faces;
    PMP::triangulate_hole(sm, h, std::back_inserter(new_faces));
    if (new_faces.empty()) {
      ++stats.holes_failed;
    } else {
      ++stats.holes_filled;
      stats.faces_added += new_faces.size();
    }
  }
  if (borders.empty()) return stats;

  const bool had_normals = mesh->normals.size() == mesh->vertices.size();
  TriangleMesh out;
  std::vector<int> index(sm.number_of_vertices() + sm.number_of_removed_vertices(), -1);
  for (const auto v : sm.vertices()) {
    index[v.idx()] = static_cast<int>(out.vertices.size());
    const Point& p = sm.point(v);
    out.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (const auto f : sm.faces()) {
    std::vector<int> poly;
    for (const auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) poly.push_back(index[v.idx()]);
    for (size_t k = 1; k + 1 < poly.size(); ++k) out.faces.emplace_back(poly[0], poly[k], poly[k + 1]);
  }
  if (had_normals) out.ComputeVertexNormals();
  *mesh = std::move(out);
  return stats;
}

}  // namespace relight
