#include "mvs/mesh_metrics.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>
#include <random>

#include "core/error.h"

namespace relight {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
using SearchTraits = CGAL::Search_traits_3<Kernel>;
using NeighborSearch = CGAL::Orthogonal_k_neighbor_search<SearchTraits>;

Point ToPoint(const Eigen::Vector3f& p) { return Point(p.x(), p.y(), p.z()); }

}  // namespace

MeshTopology AnalyzeTopology(const TriangleMesh& mesh) {
  std::map<std::pair<int, int>, int> edge_faces;
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      const int a = f[k], b = f[(k + 1) % 3];
      ++edge_faces[{std::min(a, b), std::max(a, b)}];
    }
  }
  MeshTopology t;
  t.num_edges = edge_faces.size();
  for (const auto& [edge, count] : edge_faces) {
    if (count == 1) ++t.boundary_edges;
    if (count > 2) ++t.nonmanifold_edges;
  }
  return t;
}

std::vector<Eigen::Vector3f> SampleSurface(const TriangleMesh& mesh, size_t count, uint64_t seed) {
  RELIGHT_CHECK(!mesh.faces.empty()) << "cannot sample a mesh without faces";
  std::vector<double> cumulative(mesh.faces.size());
  double total = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    total += mesh.FaceArea(static_cast<int>(f));
    cumulative[f] = total;
  }
  RELIGHT_CHECK_GT(total, 0.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3f> points;
  points.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const size_t f = std::min(mesh.faces.size() - 1,
                              size_t(std::lower_bound(cumulative.begin(), cumulative.end(), u(rng) * total) -
                                     cumulative.begin()));
    double a = u(rng), b = u(rng);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const auto& face = mesh.faces[f];
    const Eigen::Vector3f& v0 = mesh.vertices[face[0]];
    points.push_back(v0 + float(a) * (mesh.vertices[face[1]] - v0) + float(b) * (mesh.vertices[face[2]] - v0));
  }
  return points;
}

std::vector<double> DistancesToMesh(const std::vector<Eigen::Vector3f>& points, const TriangleMesh& mesh) {
  RELIGHT_CHECK(!mesh.faces.empty()) << "distance to a mesh without faces";
  std::vector<Triangle> triangles;
  triangles.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    const Point a = ToPoint(mesh.vertices[f[0]]), b = ToPoint(mesh.vertices[f[1]]), c = ToPoint(mesh.vertices[f[2]]);
    const Triangle t(a, b, c);
    if (!t.is_degenerate()) triangles.push_back(t);
  }
  RELIGHT_CHECK(!triangles.empty()) << "mesh has only degenerate triangles";
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.build();
  tree.accelerate_distance_queries();
  std::vector<double> distances(points.size());
  // Queries on a built tree are const and safe to run concurrently.
  tbb::parallel_for(size_t(0), points.size(), [&](size_t i) {
    distances[i] = std::sqrt(tree.squared_distance(ToPoint(points[i])));
  });
  return distances;
}

std::vector<double> DistancesToPoints(const std::vector<Eigen::Vector3f>& queries,
                                      const std::vector<Eigen::Vector3f>& points) {
  RELIGHT_CHECK(!points.empty()) << "distance to an empty point set";
  std::vector<Point> cgal_points;
  cgal_points.reserve(points.size());
  for (const auto& p : points) cgal_points.push_back(ToPoint(p));
  NeighborSearch::Tree tree(cgal_points.begin(), cgal_points.end());
  tree.build();
  std::vector<double> distances(queries.size());
  tbb::parallel_for(size_t(0), queries.size(), [&](size_t i) {
    NeighborSearch search(tree, ToPoint(queries[i]), 1);
    distances[i] = std::sqrt(search.begin()->second);
  });
  return distances;
}

double FractionWithin(const std::vector<double>& distances, double threshold) {
  if (distances.empty()) return 0.0;
  return double(std::count_if(distances.begin(), distances.end(), [&](double d) { return d <= threshold; })) /
         distances.size();
}

double Mean(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  double sum = 0;
  for (double v : values) sum += v;
  return sum / values.size();
}

ChamferDistance MeshChamfer(const TriangleMesh& a, const TriangleMesh& b, size_t samples, uint64_t seed) {
  ChamferDistance d;
  d.a_to_b = Mean(DistancesToMesh(SampleSurface(a, samples, seed), b));
  d.b_to_a = Mean(DistancesToMesh(SampleSurface(b, samples, seed + 1), a));
  return d;
}

}  // namespace relight
