#include "geometry/mesh_distance.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace relight {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Point ToPoint(const Eigen::Vector3f& p) { return Point(p.x(), p.y(), p.z()); }
Point ToPoint(const Eigen::Vector3d& p) { return Point(p.x(), p.y(), p.z()); }

// Barycentric coordinates of p (on or near the triangle) with respect to a, b, c.
Eigen::Vector3d Barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c) {
  const Eigen::Vector3d v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denom = d00 * d11 - d01 * d01;
  if (!(std::abs(denom) > 0)) return Eigen::Vector3d(1, 0, 0);  // numerically degenerate face: its first vertex
  const double v = (d11 * d20 - d01 * d21) / denom, w = (d00 * d21 - d01 * d20) / denom;
  const Eigen::Vector3d bary = Eigen::Vector3d(1 - v - w, v, w).cwiseMax(0.0);
  return bary / std::max(1e-12, bary.sum());
}

}  // namespace

struct SurfaceIndex::Impl {
  std::vector<Triangle> triangles;  // the mesh's non-degenerate faces
  std::vector<int> face_of;         // mesh face of each triangle
  Tree tree;
};

SurfaceIndex::SurfaceIndex(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()), mesh_(mesh) {
  RELIGHT_CHECK(!mesh.faces.empty()) << "distance to a mesh without faces";
  impl_->triangles.reserve(mesh.faces.size());
  impl_->face_of.reserve(mesh.faces.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Eigen::Vector3i& v = mesh.faces[f];
    const Triangle t(ToPoint(mesh.vertices[v[0]]), ToPoint(mesh.vertices[v[1]]), ToPoint(mesh.vertices[v[2]]));
    if (t.is_degenerate()) continue;
    impl_->triangles.push_back(t);
    impl_->face_of.push_back(static_cast<int>(f));
  }
  RELIGHT_CHECK(!impl_->triangles.empty()) << "mesh has only degenerate triangles";
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
}

SurfaceIndex::~SurfaceIndex() = default;

ClosestPoint SurfaceIndex::Query(const Eigen::Vector3d& p) const {
  const auto [point, id] = impl_->tree.closest_point_and_primitive(ToPoint(p));
  ClosestPoint c;
  c.point = Eigen::Vector3d(point.x(), point.y(), point.z());
  c.face = impl_->face_of[id - impl_->triangles.cbegin()];
  c.distance = (c.point - p).norm();
  const Eigen::Vector3i& f = mesh_.faces[c.face];
  c.barycentric = Barycentric(c.point, mesh_.vertices[f[0]].cast<double>(), mesh_.vertices[f[1]].cast<double>(),
                              mesh_.vertices[f[2]].cast<double>());
  return c;
}

double SurfaceIndex::Distance(const Eigen::Vector3d& p) const {
  return std::sqrt(impl_->tree.squared_distance(ToPoint(p)));
}

double SurfaceIndex::Interpolate(const ClosestPoint& c, const std::vector<float>& values) const {
  const Eigen::Vector3i& f = mesh_.faces[c.face];
  return c.barycentric[0] * values[f[0]] + c.barycentric[1] * values[f[1]] + c.barycentric[2] * values[f[2]];
}

std::vector<double> DistancesToMesh(const std::vector<Eigen::Vector3f>& points, const TriangleMesh& mesh) {
  const SurfaceIndex index(mesh);
  std::vector<double> distances(points.size());
  tbb::parallel_for(size_t(0), points.size(),
                    [&](size_t i) { distances[i] = index.Distance(points[i].cast<double>()); });
  return distances;
}

}  // namespace relight
