// Camera intrinsics in COLMAP's models and conventions (docs/FORMATS.md):
// the camera looks along +z, x right, y down; the centre of the top-left
// pixel is (0.5, 0.5). Distortion acts on normalised coordinates (x/z, y/z)
// exactly as in COLMAP's `src/base/camera_models.h`.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace relight {

struct Camera {
  uint32_t camera_id = 1;
  std::string model = "PINHOLE";  // SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV
  int width = 0;                  // pixels
  int height = 0;
  std::vector<double> params;     // COLMAP parameter order for `model`

  // A PINHOLE camera.
  static Camera Pinhole(uint32_t id, int width, int height, double fx, double fy, double cx, double cy);
  // COLMAP's numeric model id (0 SIMPLE_PINHOLE … 6 FULL_OPENCV); throws UserError for unsupported models.
  static int ModelId(const std::string& model);
  static std::string ModelName(int model_id);
  // Number of parameters of a model.
  static int NumParams(const std::string& model);

  double FocalX() const;
  double FocalY() const;
  double PrincipalX() const;
  double PrincipalY() const;
  // Intrinsic matrix without distortion.
  Eigen::Matrix3d K() const;
  bool HasDistortion() const;
  // Throws UserError (naming `where`) when the parameter count or size is invalid.
  void Check(const std::string& where) const;

  // Pixel of a camera-frame point (z > 0), with distortion.
  Eigen::Vector2d ImageFromCamera(const Eigen::Vector3d& point_cam) const;
  // Distorted pixel of undistorted normalised coordinates (x/z, y/z).
  Eigen::Vector2d ImageFromNormalized(const Eigen::Vector2d& normalized) const;
  // Undistorted normalised coordinates (x/z, y/z) of a pixel (inverts the distortion iteratively).
  Eigen::Vector2d NormalizedFromImage(const Eigen::Vector2d& pixel) const;
  // Unit ray direction in the camera frame through a pixel.
  Eigen::Vector3d RayFromImage(const Eigen::Vector2d& pixel) const;
  // Scales the image size and the pixel parameters (focal, principal point) by `scale`.
  void Rescale(double scale);

 private:
  Eigen::Vector2d Distort(const Eigen::Vector2d& normalized) const;
};

}  // namespace relight
