#include "mvs/mesh_metrics.h"

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"

namespace relight {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
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

}  // namespace relight
