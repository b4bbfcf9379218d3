#include "geometry/surface_sampling.h"

#include <algorithm>
#include <random>

#include "core/error.h"

namespace relight {

std::vector<Eigen::Vector3f> SampleSurface(const TriangleMesh& mesh, size_t count, uint64_t seed) {
  RELIGHT_CHECK(!mesh.faces.empty()) << "cannot sample a mesh without faces";
  std::vector<double> cumulative(mesh.faces.size());
  double total = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    total += mesh.FaceArea(static_cast<int>(f));
    cumulative[f] = total;
  }
  RELIGHT_CHECK_GT(total, 0.0) << "cannot sample a mesh without area";
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3f> points;
  points.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const size_t f =
        std::min(mesh.faces.size() - 1,
                 size_t(std::lower_bound(cumulative.begin(), cumulative.end(), u(rng) * total) - cumulative.begin()));
    // (a, b) uniform in the unit square, folded into the triangle a + b <= 1.
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

}  // namespace relight
