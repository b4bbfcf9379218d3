#include "meshing/geometry_views.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/raycaster.h"

namespace relight {
namespace {

const Eigen::Vector3f kClay(0.80f, 0.78f, 0.74f);

// Output size and the factor from output pixels to the camera's pixels.
void OutputSize(const Camera& camera, int max_size, int* width, int* height, double* to_camera) {
  const double s = std::min(1.0, double(max_size) / std::max(camera.width, camera.height));
  *width = std::max(1, int(std::lround(camera.width * s)));
  *height = std::max(1, int(std::lround(camera.height * s)));
  *to_camera = double(camera.width) / *width;
}

float Clay(const Eigen::Vector3f& normal, const Eigen::Vector3f& view_dir, const Eigen::Vector3f& up) {
  Eigen::Vector3f n = normal;
  if (n.dot(view_dir) > 0) n = -n;  // two-sided: open meshes show their inside too
  return std::min(1.0f, 0.12f + 0.68f * std::max(0.0f, -n.dot(view_dir)) + 0.25f * std::max(0.0f, n.dot(up)));
}

}  // namespace

Image RenderMeshView(const TriangleMesh& input, const Camera& camera, const ImageRecord& image, int max_size) {
  TriangleMesh mesh = input;
  if (mesh.normals.size() != mesh.vertices.size()) mesh.ComputeVertexNormals();
  int width = 0, height = 0;
  double to_camera = 1;
  OutputSize(camera, max_size, &width, &height, &to_camera);
  Image out(width, height, 3, 1.0f);
  if (mesh.faces.empty()) return out;
  const RayCaster caster({&mesh});
  const Eigen::Matrix3d world_from_cam = image.CamFromWorldRotation().transpose();
  const Eigen::Vector3f center = image.ProjectionCenter().cast<float>();
  const Eigen::Vector3f up = -(world_from_cam * Eigen::Vector3d::UnitY()).cast<float>();
  tbb::parallel_for(0, height, [&](int row) {
    for (int col = 0; col < width; ++col) {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int s = 0; s < 4; ++s) {
        const Eigen::Vector2d pixel((col + 0.25 + 0.5 * (s % 2)) * to_camera, (row + 0.25 + 0.5 * (s / 2)) * to_camera);
        Ray ray;
        ray.origin = center;
        ray.dir = (world_from_cam * camera.NormalizedFromImage(pixel).homogeneous()).normalized().cast<float>();
        const RayHit hit = caster.Intersect(ray);
        sum += hit.hit ? Eigen::Vector3f(Clay(caster.ShadingNormal(hit), ray.dir, up) * kClay)
                       : Eigen::Vector3f::Ones();
      }
      for (int c = 0; c < 3; ++c) out.at(col, row, c) = 0.25f * sum[c];
    }
  });
  return out;
}

Image RenderPointsView(const TriangleMesh& points, const Camera& camera, const ImageRecord& image, int max_size) {
  int width = 0, height = 0;
  double to_camera = 1;
  OutputSize(camera, max_size, &width, &height, &to_camera);
  Image out(width, height, 3, 1.0f);
  std::vector<float> depth(size_t(width) * height, std::numeric_limits<float>::infinity());
  const bool has_normals = points.normals.size() == points.vertices.size();
  const Eigen::Matrix3d world_from_cam = image.CamFromWorldRotation().transpose();
  const Eigen::Vector3d center = image.ProjectionCenter();
  const Eigen::Vector3f up = -(world_from_cam * Eigen::Vector3d::UnitY()).cast<float>();
  for (size_t i = 0; i < points.vertices.size(); ++i) {
    const Eigen::Vector3d p_world = points.vertices[i].cast<double>();
    const Eigen::Vector3d p_cam = image.CamFromWorld(p_world);
    if (p_cam.z() <= 0) continue;
    const Eigen::Vector2d pixel = camera.ImageFromCamera(p_cam) / to_camera;
    const Eigen::Vector3f view_dir = (p_world - center).normalized().cast<float>();
    const float shade = has_normals ? Clay(points.normals[i], view_dir, up) : 0.3f;
    // A dot covering the output pixels within 0.75 px of the projection.
    for (int y = int(std::floor(pixel.y() - 0.75)); y <= int(std::floor(pixel.y() + 0.75)); ++y) {
      for (int x = int(std::floor(pixel.x() - 0.75)); x <= int(std::floor(pixel.x() + 0.75)); ++x) {
        if (x < 0 || y < 0 || x >= width || y >= height) continue;
        float& d = depth[size_t(y) * width + x];
        if (p_cam.z() >= d) continue;
        d = float(p_cam.z());
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = has_normals ? shade * kClay[c] : shade;
      }
    }
  }
  return out;
}

std::vector<const ImageRecord*> SpreadViews(const Reconstruction& model, int count) {
  std::vector<const ImageRecord*> all;
  for (const auto& [id, im] : model.images) all.push_back(&im);
  std::sort(all.begin(), all.end(), [](const auto* a, const auto* b) { return a->name < b->name; });
  if (count <= 0 || all.size() <= size_t(count)) return all;
  std::vector<const ImageRecord*> out;
  for (int k = 0; k < count; ++k) out.push_back(all[size_t(std::floor((k + 0.5) * all.size() / count))]);
  return out;
}

}  // namespace relight
