// The only translation unit with CGAL includes (see mesh_cleanup.h).
#include "meshing/mesh_cleanup.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include "core/error.h"
#include "core/log.h"
#include "core/timer.h"
#include "geometry/point_grid.h"

namespace relight {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Face = SurfaceMesh::Face_index;
using Halfedge = SurfaceMesh::Halfedge_index;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace SMS = CGAL::Surface_mesh_simplification;

SurfaceMesh ToSurfaceMesh(const TriangleMesh& input, MeshCleanupSummary* summary) {
  std::vector<Point> points;
  points.reserve(input.vertices.size());
  for (const auto& v : input.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(input.faces.size());
  // Faces with an index out of range or on a non-finite vertex are dropped:
  // CGAL's predicates and AABB trees assume finite coordinates.
  const auto usable = [&](int i) { return i >= 0 && size_t(i) < input.vertices.size() && input.vertices[i].allFinite(); };
  for (const auto& f : input.faces) {
    if (usable(f[0]) && usable(f[1]) && usable(f[2])) {
      polygons.push_back({size_t(f[0]), size_t(f[1]), size_t(f[2])});
    } else {
      ++summary->invalid_faces_removed;
    }
  }

  const size_t points_before = points.size(), polygons_before = polygons.size();
  PMP::repair_polygon_soup(points, polygons);
  summary->duplicate_points_merged = points_before > points.size() ? points_before - points.size() : 0;
  summary->soup_polygons_removed = polygons_before - polygons.size();
  const size_t points_repaired = points.size();
  PMP::orient_polygon_soup(points, polygons);  // duplicates points at non-manifold edges/vertices
  summary->non_manifold_points_duplicated = points.size() - points_repaired;
  SurfaceMesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  return mesh;
}

TriangleMesh FromSurfaceMesh(const SurfaceMesh& mesh) {
  TriangleMesh out;
  std::map<SurfaceMesh::Vertex_index, int> index;
  out.vertices.reserve(mesh.number_of_vertices());
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    index[v] = static_cast<int>(out.vertices.size());
    out.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  out.faces.reserve(mesh.number_of_faces());
  for (auto f : mesh.faces()) {
    Eigen::Vector3i tri;
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (k < 3) tri[k] = index[v];
      ++k;
    }
    RELIGHT_CHECK_EQ(k, 3) << "non-triangular face after clean-up";
    out.faces.push_back(tri);
  }
  return out;
}

// Data points per component: each point counts for the component of its
// nearest vertex within `radius` (a PointGrid of cell `radius`).
std::vector<double> ComponentSupport(const SurfaceMesh& mesh, const SurfaceMesh::Property_map<Face, std::size_t>& fcc,
                                     std::size_t num, const std::vector<Eigen::Vector3d>& points, double radius) {
  std::vector<double> support(num, 0.0);
  if (radius <= 0 || points.empty()) return support;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::size_t> vertex_component;
  for (auto v : mesh.vertices()) {
    const auto h = mesh.halfedge(v);
    if (h == SurfaceMesh::null_halfedge()) continue;
    Face f = mesh.face(h);
    if (f == SurfaceMesh::null_face()) f = mesh.face(mesh.opposite(h));
    if (f == SurfaceMesh::null_face()) continue;
    const Point& p = mesh.point(v);
    vertices.emplace_back(p.x(), p.y(), p.z());
    vertex_component.push_back(fcc[f]);
  }
  const PointGrid grid(std::move(vertices), radius);
  for (const Eigen::Vector3d& p : points) {
    if (const std::optional<std::size_t> nearest = grid.Nearest(p, radius)) support[vertex_component[*nearest]] += 1;
  }
  return support;
}

// Keeps the best components (up to max_components, each scoring at least
// min_component_fraction of the best): ranked by their support in the data
// points when there are any near the mesh, else by area.
void KeepLargestComponents(const MeshCleanupOptions& options, SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  auto fccmap = mesh->add_property_map<Face, std::size_t>("f:relight_cc", 0).first;
  const std::size_t num = PMP::connected_components(*mesh, fccmap);
  summary->components_found = static_cast<int>(num);
  std::vector<double> area(num, 0.0);
  std::vector<size_t> faces(num, 0);
  for (Face f : mesh->faces()) {
    area[fccmap[f]] += PMP::face_area(f, *mesh);
    ++faces[fccmap[f]];
  }
  std::vector<double> score = area;
  summary->component_ranking = "area";
  if (options.support_points != nullptr && num > 1) {
    const std::vector<double> support =
        ComponentSupport(*mesh, fccmap, num, *options.support_points, options.support_radius);
    if (*std::max_element(support.begin(), support.end()) > 0) {
      score = support;
      summary->component_ranking = "support";
    }
  }
  std::vector<std::size_t> order(num);
  for (size_t i = 0; i < num; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return score[a] != score[b] ? score[a] > score[b] : area[a] > area[b];
  });
  std::vector<std::size_t> keep;
  for (size_t k = 0; k < num && static_cast<int>(k) < options.max_components; ++k) {
    if (k == 0 || score[order[k]] >= options.min_component_fraction * score[order[0]]) keep.push_back(order[k]);
  }
  summary->components_removed = static_cast<int>(num - keep.size());
  for (size_t k = 0; k < num; ++k) {
    if (std::find(keep.begin(), keep.end(), k) == keep.end()) summary->faces_removed_with_components += faces[k];
  }
  if (keep.size() < num) PMP::keep_connected_components(*mesh, keep, fccmap);
  mesh->remove_property_map(fccmap);
  mesh->collect_garbage();
}

double BboxDiagonal(const SurfaceMesh& mesh) {
  const CGAL::Bbox_3 box = PMP::bbox(mesh);
  return std::sqrt(CGAL::square(box.xmax() - box.xmin()) + CGAL::square(box.ymax() - box.ymin()) +
                   CGAL::square(box.zmax() - box.zmin()));
}

void FillSmallHoles(const MeshCleanupOptions& options, SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  std::vector<Halfedge> borders;
  PMP::extract_boundary_cycles(*mesh, std::back_inserter(borders));
  const double diagonal = BboxDiagonal(*mesh);
  for (Halfedge h : borders) {
    int edges = 0;
    CGAL::Bbox_3 box;
    for (Halfedge b : CGAL::halfedges_around_face(h, *mesh)) {
      ++edges;
      box += mesh->point(mesh->target(b)).bbox();
    }
    const double width = std::sqrt(CGAL::square(box.xmax() - box.xmin()) + CGAL::square(box.ymax() - box.ymin()) +
                                   CGAL::square(box.zmax() - box.zmin()));
    if (edges > options.max_hole_edges || width > options.max_hole_fraction * diagonal) {
      ++summary->holes_left;
      continue;
    }
    std::vector<Face> new_faces;
    std::vector<SurfaceMesh::Vertex_index> new_vertices;
    const auto result = PMP::triangulate_refine_and_fair_hole(*mesh, h, std::back_inserter(new_faces),
                                                              std::back_inserter(new_vertices));
    if (!std::get<0>(result)) RLOG_DEBUG("hole of {} edges: fairing failed, kept the refined patch", edges);
    if (new_faces.empty()) {
      ++summary->holes_left;
    } else {
      ++summary->holes_filled;
      summary->hole_faces_added += new_faces.size();
    }
  }
}

// Edge collapse towards `target_vertices` (only ever reduces).
void Decimate(SurfaceMesh* mesh, size_t target_vertices) {
  if (mesh->number_of_vertices() <= target_vertices) return;
  // Edges scale with vertices (E ≈ 3V on closed meshes); aim the edge count proportionally.
  const double ratio = double(target_vertices) / mesh->number_of_vertices();
  const size_t target_edges = std::max<size_t>(6, static_cast<size_t>(ratio * mesh->number_of_edges()));
  SMS::Count_stop_predicate<SurfaceMesh> stop(target_edges);
  SMS::edge_collapse(*mesh, stop);
  mesh->collect_garbage();
}

// Removes `doomed` faces, then the vertices left without a face, and splits
// the vertices removal made non-manifold.
void RemoveFaces(const std::vector<Face>& doomed, SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  for (Face f : doomed) {
    if (!mesh->is_removed(f)) CGAL::Euler::remove_face(mesh->halfedge(f), *mesh);
  }
  PMP::remove_isolated_vertices(*mesh);
  mesh->collect_garbage();
  summary->non_manifold_points_duplicated += PMP::duplicate_non_manifold_vertices(*mesh);
}

// Removes faces on non-finite points, degenerate faces and the vertices they
// leave, and splits non-manifold vertices. Hole filling can produce all of
// them: fairing a large hole (issue 34: mesh.max_hole_edges 5000,
// max_hole_fraction 1 on a poor MVS surface) may place vertices at infinity
// or NaN, and CGAL's later steps assume finite, valid input.
void RemoveInvalidFaces(SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  // Non-finite points (a failed fairing solve) and the faces on them.
  const auto finite = [&](SurfaceMesh::Vertex_index v) {
    const Point& p = mesh->point(v);
    return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
  };
  std::vector<Face> doomed;
  for (auto v : mesh->vertices()) {
    if (finite(v) || mesh->halfedge(v) == SurfaceMesh::null_halfedge()) continue;
    for (Face f : CGAL::faces_around_target(mesh->halfedge(v), *mesh)) {
      if (f != SurfaceMesh::null_face()) doomed.push_back(f);
    }
  }
  std::sort(doomed.begin(), doomed.end());
  doomed.erase(std::unique(doomed.begin(), doomed.end()), doomed.end());
  summary->invalid_faces_removed += doomed.size();
  RemoveFaces(doomed, mesh, summary);  // also removes the vertices left on no face

  // Degenerate faces (collinear or coincident corners), then pinched vertices.
  const size_t faces_before = mesh->number_of_faces();
  PMP::remove_degenerate_faces(*mesh);
  mesh->collect_garbage();
  summary->degenerate_faces_removed += faces_before - mesh->number_of_faces();
  summary->non_manifold_points_duplicated += PMP::duplicate_non_manifold_vertices(*mesh);
}

// Brings the mesh into the state CGAL's isotropic remeshing assumes (a valid
// triangle mesh: finite points, no degenerate faces, manifold vertices, no
// self-intersections: a hole patch folded through the surface is the typical
// one); remeshing other input can segfault. Returns "" when the mesh can be
// remeshed, else why not (then it is only decimated).
std::string PrepareForRemeshing(SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  RemoveInvalidFaces(mesh, summary);
  // Self-intersections: both faces of every intersecting pair go; the holes
  // they leave are remeshed like any border.
  for (int round = 0; round < 3 && mesh->number_of_faces() > 0; ++round) {
    std::vector<std::pair<Face, Face>> pairs;
    PMP::self_intersections(faces(*mesh), *mesh, std::back_inserter(pairs));
    if (pairs.empty()) break;
    std::vector<Face> crossing;
    for (const auto& [a, b] : pairs) {
      crossing.push_back(a);
      crossing.push_back(b);
    }
    std::sort(crossing.begin(), crossing.end());
    crossing.erase(std::unique(crossing.begin(), crossing.end()), crossing.end());
    summary->self_intersecting_faces_removed += crossing.size();
    RemoveFaces(crossing, mesh, summary);
    PMP::remove_degenerate_faces(*mesh);
    mesh->collect_garbage();
  }

  if (mesh->number_of_faces() == 0) return "no face is left after removing invalid ones";
  if (!CGAL::is_triangle_mesh(*mesh) || !CGAL::is_valid_polygon_mesh(*mesh)) return "the mesh is not a valid triangle mesh";
  if (PMP::does_self_intersect(*mesh)) return "self-intersections remain after three rounds of removal";
  return "";
}

void Resample(const MeshCleanupOptions& options, SurfaceMesh* mesh, MeshCleanupSummary* summary) {
  if (options.target_vertices <= 0) return;
  const size_t target = static_cast<size_t>(options.target_vertices);
  auto within = [&] {
    const double r = double(mesh->number_of_vertices()) / target;
    return std::abs(r - 1.0) <= options.vertex_tolerance;
  };
  if (!options.remesh) {
    for (int pass = 0; pass < 4 && !within() && mesh->number_of_vertices() > target; ++pass) {
      Decimate(mesh, target);
      ++summary->resample_passes;
    }
    return;
  }
  // Remeshing a huge input directly is slow: collapse to twice the budget first.
  if (mesh->number_of_vertices() > 4 * target) Decimate(mesh, 2 * target);
  const std::string invalid = PrepareForRemeshing(mesh, summary);
  // Equilateral triangles of side L, F ≈ 2V faces: A = 2V · (√3/4) L².
  const double area = invalid.empty() ? PMP::area(*mesh) : 0.0;
  double length = std::sqrt(2.0 * area / (std::sqrt(3.0) * double(target)));
  if (!invalid.empty() || !std::isfinite(length) || length <= 0) {
    summary->remesh_skipped = invalid.empty() ? "the surface has no area" : invalid;
    RLOG_WARN("isotropic remeshing skipped ({}); decimating only", summary->remesh_skipped);
    Decimate(mesh, target);
    ++summary->resample_passes;
    return;
  }
  for (int pass = 0; pass < 5; ++pass) {
    PMP::isotropic_remeshing(faces(*mesh), length, *mesh,
                             CGAL::parameters::number_of_iterations(options.remesh_iterations));
    mesh->collect_garbage();
    ++summary->resample_passes;
    summary->target_edge_length = length;
    RLOG_DEBUG("remeshing pass {}: edge length {:.5g} -> {} vertices (target {})", pass + 1, length,
               mesh->number_of_vertices(), target);
    if (within() || mesh->number_of_vertices() == 0) break;
    length *= std::sqrt(double(mesh->number_of_vertices()) / target);
  }
}

}  // namespace

TriangleMesh CleanMesh(const TriangleMesh& input, const MeshCleanupOptions& options, const std::string& where,
                       MeshCleanupSummary* summary) {
  *summary = MeshCleanupSummary();
  summary->input_vertices = input.vertices.size();
  summary->input_faces = input.faces.size();
  if (input.faces.empty()) RELIGHT_USER_ERROR() << where << " has no faces; a triangle mesh is needed";
  Timer step;
  auto lap = [&](const char* name) {
    summary->step_seconds.emplace_back(name, step.Seconds());
    step.Restart();
  };

  SurfaceMesh mesh = ToSurfaceMesh(input, summary);
  lap("soup repair");
  const size_t faces_before = mesh.number_of_faces();
  PMP::remove_degenerate_faces(mesh);
  mesh.collect_garbage();
  summary->degenerate_faces_removed = faces_before - mesh.number_of_faces();
  summary->non_manifold_points_duplicated += PMP::duplicate_non_manifold_vertices(mesh);
  lap("degeneracies");
  if (mesh.number_of_faces() == 0) {
    RELIGHT_USER_ERROR() << where << ": no valid triangle is left after removing degenerate faces";
  }

  KeepLargestComponents(options, &mesh, summary);
  lap("components");
  if (options.max_hole_edges > 0) {
    FillSmallHoles(options, &mesh, summary);
    RemoveInvalidFaces(&mesh, summary);
    if (mesh.number_of_faces() == 0) RELIGHT_USER_ERROR() << where << ": no valid triangle is left after filling holes";
  }
  lap("holes");
  Resample(options, &mesh, summary);
  lap("resample");
  // Remeshing can leave degenerate slivers and pinched vertices in rare cases.
  PMP::remove_degenerate_faces(mesh);
  PMP::duplicate_non_manifold_vertices(mesh);
  mesh.collect_garbage();

  summary->closed = CGAL::is_closed(mesh);
  if (summary->closed) {
    // Every closed component outward (is_outward_oriented judges one component only).
    summary->orientation_reversed = !PMP::is_outward_oriented(mesh);
    PMP::orient(mesh, CGAL::parameters::outward_orientation(true));
  }
  lap("orientation");

  TriangleMesh out = FromSurfaceMesh(mesh);
  out.ComputeVertexNormals();
  summary->output_vertices = out.vertices.size();
  summary->output_faces = out.faces.size();
  return out;
}

}  // namespace relight
