// The inputs and outputs of stereo matching: a view (pinhole camera plus a
// grey image at the processing resolution) and a depth + normal map.
//
// Pixel convention (docs/FORMATS.md): pixel (col, row) has its centre at
// (col + 0.5, row + 0.5), so `DepthNormalMap::depth` is the camera-space z of
// the surface along the ray K⁻¹ (col + 0.5, row + 0.5, 1). COLMAP's dense
// tools instead read map entry (row, col) as the surface along K⁻¹ (col, row, 1)
// (`stereo_fusion` back-projects `inv_P · (col·d, row·d, d)`). The
// conversions below move each pixel's plane (depth + normal) between the two
// rays, which is exact for a locally planar surface, so fused points lie on
// the estimated surface instead of half a pixel beside it.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/reconstruction.h"
#include "image/image.h"
#include "mvs/colmap_mat.h"

namespace relight {

// One undistorted view at the resolution stereo runs at.
struct StereoView {
  std::string name;                  // image name in the COLMAP model (file in dense/images)
  uint32_t image_id = 0;             // COLMAP image id
  int width = 0;                     // processing size in pixels
  int height = 0;
  int image_width = 0;               // size of the undistorted image file (the model's camera)
  int image_height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();       // pinhole intrinsics at the processing size
  Eigen::Matrix3d R_cam_from_world = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_cam_from_world = Eigen::Vector3d::Zero();
  Image gray;                        // 1 channel, encoded grey in [0, 1], width × height (empty until loaded)

  // Camera centre in world coordinates.
  Eigen::Vector3d CenterWorld() const { return -R_cam_from_world.transpose() * t_cam_from_world; }
};

// Pinhole view of a registered image of an undistorted COLMAP model, scaled
// so the longest side is at most `max_image_size` (0: unscaled). The scale is
// applied per axis from the rounded integer size, as `stereo_fusion` does
// when depth maps are smaller than the images. Throws UserError for a
// camera model with distortion (the workspace must be undistorted).
StereoView MakeStereoView(const Reconstruction& model, const ImageRecord& image, int max_image_size);

// A per-pixel depth and normal map of one view.
struct DepthNormalMap {
  int width = 0;
  int height = 0;
  std::vector<float> depth;             // camera z along the pixel-centre ray; 0 = no estimate
  std::vector<Eigen::Vector3f> normal_cam;  // unit, camera frame, facing the camera (n · ray < 0); zero when no estimate
  std::vector<float> cost;              // aggregated matching cost of the estimate (empty when unknown)

  DepthNormalMap() = default;
  DepthNormalMap(int w, int h)
      : width(w), height(h), depth(size_t(w) * h, 0.0f), normal_cam(size_t(w) * h, Eigen::Vector3f::Zero()) {}
  size_t index(int col, int row) const { return size_t(row) * width + col; }
  // Fraction of pixels with a depth.
  double ValidFraction() const;
};

// COLMAP depth (1 channel) and normal (3 channels) maps of `map`, each
// pixel's plane re-intersected with COLMAP's ray through (col, row).
void ToColmapMaps(const DepthNormalMap& map, const Eigen::Matrix3d& K, ColmapMat* depth, ColmapMat* normal);
// Inverse of ToColmapMaps. Throws UserError naming `where` when the two maps disagree in size.
DepthNormalMap FromColmapMaps(const ColmapMat& depth, const ColmapMat& normal, const Eigen::Matrix3d& K,
                              const std::string& where);

}  // namespace relight
