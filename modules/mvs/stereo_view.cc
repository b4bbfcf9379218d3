#include "mvs/stereo_view.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace relight {

StereoView MakeStereoView(const Reconstruction& model, const ImageRecord& image, int max_image_size) {
  const auto cam_it = model.cameras.find(image.camera_id);
  RELIGHT_CHECK(cam_it != model.cameras.end()) << "image " << image.name << " has no camera";
  const Camera& camera = cam_it->second;
  if (camera.model != "PINHOLE" && camera.model != "SIMPLE_PINHOLE") {
    RELIGHT_USER_ERROR() << "image '" << image.name << "' has a " << camera.model
                         << " camera: the mvs stage needs an undistorted workspace (PINHOLE cameras, as written by "
                         << "colmap image_undistorter into <sfm>/dense/)";
  }
  StereoView view;
  view.name = image.name;
  view.image_id = image.image_id;
  view.width = camera.width;
  view.height = camera.height;
  view.image_width = camera.width;
  view.image_height = camera.height;
  double sx = 1.0, sy = 1.0;
  const int longest = std::max(camera.width, camera.height);
  if (max_image_size > 0 && longest > max_image_size) {
    const double s = double(max_image_size) / longest;
    view.width = std::max(1, static_cast<int>(std::lround(camera.width * s)));
    view.height = std::max(1, static_cast<int>(std::lround(camera.height * s)));
    sx = double(view.width) / camera.width;
    sy = double(view.height) / camera.height;
  }
  view.K << camera.FocalX() * sx, 0, camera.PrincipalX() * sx,  //
      0, camera.FocalY() * sy, camera.PrincipalY() * sy,         //
      0, 0, 1;
  view.R_cam_from_world = image.CamFromWorldRotation();
  view.t_cam_from_world = image.cam_from_world_translation;
  return view;
}

double DepthNormalMap::ValidFraction() const {
  if (depth.empty()) return 0.0;
  const size_t valid = std::count_if(depth.begin(), depth.end(), [](float d) { return d > 0.0f; });
  return double(valid) / depth.size();
}

namespace {

// Depth along `to_ray` (z-normalised) of the plane through `depth · from_ray` with normal `n`;
// returns `depth` unchanged when the plane is (nearly) parallel to the new ray.
float Reintersect(float depth, const Eigen::Vector3f& n, const Eigen::Vector3f& from_ray,
                  const Eigen::Vector3f& to_ray) {
  const float denom = n.dot(to_ray);
  const float numer = depth * n.dot(from_ray);
  if (!(denom < -1e-3f * to_ray.norm())) return depth;
  const float d = numer / denom;
  // Half a pixel cannot move a visible surface by more than a few percent; anything else is a grazing plane.
  if (!(d > 0.9f * depth && d < 1.1f * depth)) return depth;
  return d;
}

}  // namespace

void ToColmapMaps(const DepthNormalMap& map, const Eigen::Matrix3d& K, ColmapMat* depth, ColmapMat* normal) {
  const Eigen::Matrix3f K_inv = K.inverse().cast<float>();
  *depth = ColmapMat(map.width, map.height, 1);
  *normal = ColmapMat(map.width, map.height, 3);
  for (int row = 0; row < map.height; ++row) {
    for (int col = 0; col < map.width; ++col) {
      const size_t i = map.index(col, row);
      const float d = map.depth[i];
      if (!(d > 0.0f)) continue;
      const Eigen::Vector3f& n = map.normal_cam[i];
      const Eigen::Vector3f center_ray = K_inv * Eigen::Vector3f(col + 0.5f, row + 0.5f, 1.0f);
      const Eigen::Vector3f colmap_ray = K_inv * Eigen::Vector3f(float(col), float(row), 1.0f);
      depth->at(row, col) = Reintersect(d, n, center_ray, colmap_ray);
      for (int c = 0; c < 3; ++c) normal->at(row, col, c) = n[c];
    }
  }
}

DepthNormalMap FromColmapMaps(const ColmapMat& depth, const ColmapMat& normal, const Eigen::Matrix3d& K,
                              const std::string& where) {
  if (depth.channels != 1 || normal.channels != 3 || depth.width != normal.width || depth.height != normal.height) {
    RELIGHT_USER_ERROR() << "depth and normal maps of '" << where << "' disagree in size (" << depth.width << "x"
                         << depth.height << "x" << depth.channels << " vs " << normal.width << "x" << normal.height
                         << "x" << normal.channels << "); delete them and rerun the mvs stage";
  }
  const Eigen::Matrix3f K_inv = K.inverse().cast<float>();
  DepthNormalMap map(depth.width, depth.height);
  for (int row = 0; row < map.height; ++row) {
    for (int col = 0; col < map.width; ++col) {
      const float d = depth.at(row, col);
      if (!(d > 0.0f)) continue;
      Eigen::Vector3f n(normal.at(row, col, 0), normal.at(row, col, 1), normal.at(row, col, 2));
      const float len = n.norm();
      if (!(len > 0.5f)) continue;  // COLMAP writes zero normals for filtered pixels
      n /= len;
      const Eigen::Vector3f center_ray = K_inv * Eigen::Vector3f(col + 0.5f, row + 0.5f, 1.0f);
      const Eigen::Vector3f colmap_ray = K_inv * Eigen::Vector3f(float(col), float(row), 1.0f);
      const size_t i = map.index(col, row);
      map.depth[i] = Reintersect(d, n, colmap_ray, center_ray);
      map.normal_cam[i] = n;
    }
  }
  return map;
}

}  // namespace relight
