#include "mvs/mesh_preview.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "geometry/raycaster.h"

namespace relight {

Image RenderMeshPreview(const TriangleMesh& input, const StereoView& view) {
  TriangleMesh mesh = input;
  if (mesh.normals.size() != mesh.vertices.size()) mesh.ComputeVertexNormals();
  const RayCaster caster({&mesh});
  const Eigen::Matrix3f world_from_cam = view.R_cam_from_world.transpose().cast<float>();
  const Eigen::Vector3f center = view.CenterWorld().cast<float>();
  const Eigen::Matrix3f K_inv = view.K.inverse().cast<float>();
  const Eigen::Vector3f up_world = -(world_from_cam * Eigen::Vector3f(0, 1, 0));
  const Eigen::Vector3f clay(0.80f, 0.78f, 0.74f);
  Image image(view.width, view.height, 3, 1.0f);
  tbb::parallel_for(0, view.height, [&](int row) {
    for (int col = 0; col < view.width; ++col) {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int s = 0; s < 4; ++s) {
        const float u = col + 0.25f + 0.5f * (s % 2), v = row + 0.25f + 0.5f * (s / 2);
        Ray ray;
        ray.origin = center;
        ray.dir = (world_from_cam * (K_inv * Eigen::Vector3f(u, v, 1.0f))).normalized();
        const RayHit hit = caster.Intersect(ray);
        if (!hit.hit) {
          sum += Eigen::Vector3f::Ones();
          continue;
        }
        Eigen::Vector3f n = caster.ShadingNormal(hit);
        if (n.dot(ray.dir) > 0) n = -n;  // two-sided: open meshes show their inside too
        const float shade = 0.12f + 0.68f * std::max(0.0f, -n.dot(ray.dir)) + 0.25f * std::max(0.0f, n.dot(up_world));
        sum += std::min(1.0f, shade) * clay;
      }
      for (int c = 0; c < 3; ++c) image.at(col, row, c) = 0.25f * sum[c];
    }
  });
  return image;
}

}  // namespace relight
