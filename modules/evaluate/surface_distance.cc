#include "evaluate/surface_distance.h"

#include <memory>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <random>

#include "core/error.h"
#include "evaluate/image_metrics.h"

namespace relight {
namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Point ToPoint(const Eigen::Vector3f& p) { return Point(p.x(), p.y(), p.z()); }

// Barycentric coordinates of p (on or near the triangle) with respect to a, b, c.
Eigen::Vector3d Barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c) {
  const Eigen::Vector3d v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denom = d00 * d11 - d01 * d01;
  if (!(std::abs(denom) > 0)) return Eigen::Vector3d(1, 0, 0);  // degenerate face: its first vertex
  const double v = (d11 * d20 - d01 * d21) / denom, w = (d00 * d21 - d01 * d20) / denom;
  const Eigen::Vector3d bary = Eigen::Vector3d(1 - v - w, v, w).cwiseMax(0.0);
  return bary / std::max(1e-12, bary.sum());
}
}  // namespace

struct SurfaceIndex::Impl {
  std::vector<Triangle> triangles;
  Tree tree;
};

SurfaceIndex::SurfaceIndex(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()), mesh_(mesh) {
  RELIGHT_CHECK(!mesh.faces.empty()) << "closest points on a mesh without faces";
  impl_->triangles.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    impl_->triangles.emplace_back(ToPoint(mesh.vertices[f[0]]), ToPoint(mesh.vertices[f[1]]),
                                  ToPoint(mesh.vertices[f[2]]));
  }
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.accelerate_distance_queries();
}

SurfaceIndex::~SurfaceIndex() = default;

ClosestPoint SurfaceIndex::Query(const Eigen::Vector3d& p) const {
  const auto [point, id] = impl_->tree.closest_point_and_primitive(Point(p.x(), p.y(), p.z()));
  ClosestPoint c;
  c.point = Eigen::Vector3d(point.x(), point.y(), point.z());
  c.face = static_cast<int>(id - impl_->triangles.cbegin());
  c.distance = (c.point - p).norm();
  const Eigen::Vector3i& f = mesh_.faces[c.face];
  c.barycentric = Barycentric(c.point, mesh_.vertices[f[0]].cast<double>(), mesh_.vertices[f[1]].cast<double>(),
                              mesh_.vertices[f[2]].cast<double>());
  return c;
}

double SurfaceIndex::Interpolate(const ClosestPoint& c, const std::vector<float>& values) const {
  const Eigen::Vector3i& f = mesh_.faces[c.face];
  return c.barycentric[0] * values[f[0]] + c.barycentric[1] * values[f[1]] + c.barycentric[2] * values[f[2]];
}

std::vector<Eigen::Vector3d> SampleSurfaceUniform(const TriangleMesh& mesh, size_t count, uint64_t seed) {
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
  std::vector<Eigen::Vector3d> points;
  points.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const size_t f =
        std::min(mesh.faces.size() - 1,
                 size_t(std::lower_bound(cumulative.begin(), cumulative.end(), u(rng) * total) - cumulative.begin()));
    double a = u(rng), b = u(rng);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const auto& face = mesh.faces[f];
    const Eigen::Vector3d v0 = mesh.vertices[face[0]].cast<double>();
    points.push_back(v0 + a * (mesh.vertices[face[1]].cast<double>() - v0) +
                     b * (mesh.vertices[face[2]].cast<double>() - v0));
  }
  return points;
}

MeshDistances CompareMeshes(const TriangleMesh& estimate, const TriangleMesh& truth, size_t samples, uint64_t seed,
                            const TriangleMesh* truth_context) {
  MeshDistances d;
  d.samples = samples;
  d.diagonal = truth.BoundingBox().diagonal().norm();
  const SurfaceIndex truth_index(truth), estimate_index(estimate);
  std::unique_ptr<SurfaceIndex> context_index;
  if (truth_context != nullptr && truth_context->num_faces() > 0) {
    context_index = std::make_unique<SurfaceIndex>(*truth_context);
  }
  auto distances = [&](const std::vector<Eigen::Vector3d>& points, const SurfaceIndex& index,
                       const SurfaceIndex* also) {
    std::vector<double> out(points.size());
    tbb::parallel_for(size_t(0), points.size(), [&](size_t k) {
      out[k] = index.Query(points[k]).distance;
      if (also != nullptr) out[k] = std::min(out[k], also->Query(points[k]).distance);
    });
    return out;
  };
  std::vector<Eigen::Vector3d> estimate_points = SampleSurfaceUniform(estimate, samples, seed);
  if (context_index) {
    // Only the estimate around the object counts; the ground it stands on is true surface too.
    Eigen::AlignedBox3d box = truth.BoundingBox().cast<double>();
    box.min().array() -= 0.1 * d.diagonal;
    box.max().array() += 0.1 * d.diagonal;
    std::vector<Eigen::Vector3d> inside;
    for (const Eigen::Vector3d& p : estimate_points) {
      if (box.contains(p)) inside.push_back(p);
    }
    // An estimate with no surface around the object (a mesh stage that kept the
    // wrong part) is scored whole: far from everything, not undefined.
    d.estimate_samples_near_object = inside.size();
    if (!inside.empty()) estimate_points = std::move(inside);
  } else {
    d.estimate_samples_near_object = estimate_points.size();
  }
  std::vector<double> acc = distances(estimate_points, truth_index, context_index.get());
  std::vector<double> comp = distances(SampleSurfaceUniform(truth, samples, seed + 1), estimate_index, nullptr);
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  d.accuracy_mean = mean(acc);
  d.completeness_mean = mean(comp);
  d.chamfer = 0.5 * (d.accuracy_mean + d.completeness_mean);
  d.accuracy_p90 = Percentile(&acc, 90);
  d.completeness_p90 = Percentile(&comp, 90);
  return d;
}

}  // namespace relight
