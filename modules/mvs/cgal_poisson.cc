#include "mvs/cgal_poisson.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/poisson_surface_reconstruction.h>
#include <CGAL/property_map.h>

#include <utility>
#include <vector>

#include "core/error.h"
#include "core/timer.h"

namespace relight {

TriangleMesh CgalPoissonReconstruct(const TriangleMesh& points, CgalPoissonStats* stats) {
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Point = Kernel::Point_3;
  using Vector = Kernel::Vector_3;
  using PointWithNormal = std::pair<Point, Vector>;
  using SurfaceMesh = CGAL::Surface_mesh<Point>;
  Timer timer;
  if (points.normals.size() != points.vertices.size()) {
    RELIGHT_USER_ERROR() << "CGAL Poisson reconstruction needs oriented points (nx, ny, nz)";
  }
  std::vector<PointWithNormal> input;
  input.reserve(points.vertices.size());
  for (size_t i = 0; i < points.vertices.size(); ++i) {
    const auto& p = points.vertices[i];
    const auto& n = points.normals[i];
    if (!(n.squaredNorm() > 0.25f)) continue;
    input.emplace_back(Point(p.x(), p.y(), p.z()), Vector(n.x(), n.y(), n.z()));
  }
  if (input.size() < 100) {
    RELIGHT_USER_ERROR() << "only " << input.size() << " oriented points: too few for a Poisson surface";
  }
  const CGAL::First_of_pair_property_map<PointWithNormal> point_map;
  const CGAL::Second_of_pair_property_map<PointWithNormal> normal_map;
  const double spacing = CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
      input, 6, CGAL::parameters::point_map(point_map));
  SurfaceMesh output;
  if (!CGAL::poisson_surface_reconstruction_delaunay(input.begin(), input.end(), point_map, normal_map, output,
                                                     spacing)) {
    RELIGHT_USER_ERROR() << "CGAL Poisson reconstruction failed on " << input.size()
                         << " points (the implicit function could not be solved); try mvs.mesher: colmap_poisson";
  }
  TriangleMesh mesh;
  std::vector<int> index(output.number_of_vertices(), -1);
  for (const auto v : output.vertices()) {
    index[v.idx()] = static_cast<int>(mesh.vertices.size());
    const Point& p = output.point(v);
    mesh.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (const auto f : output.faces()) {
    std::vector<int> poly;
    for (const auto v : CGAL::vertices_around_face(output.halfedge(f), output)) poly.push_back(index[v.idx()]);
    for (size_t k = 1; k + 1 < poly.size(); ++k) mesh.faces.emplace_back(poly[0], poly[k], poly[k + 1]);
  }
  mesh.ComputeVertexNormals();
  if (stats != nullptr) {
    stats->average_spacing = spacing;
    stats->num_points = input.size();
    stats->seconds = timer.Seconds();
  }
  return mesh;
}

}  // namespace relight
