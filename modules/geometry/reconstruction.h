// A COLMAP sparse model (cameras, registered images, 3D points), read from and
// written to COLMAP's documented text and binary formats
// (https://colmap.github.io/format.html). COLMAP ships no library in Debian,
// so the formats are parsed here.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "geometry/camera.h"

namespace relight {

// An observation of a 3D point in an image.
struct Point2D {
  Eigen::Vector2d xy;                      // pixel coordinates
  uint64_t point3d_id = kInvalidPoint3D;   // kInvalidPoint3D when not triangulated
  static constexpr uint64_t kInvalidPoint3D = ~uint64_t(0);
};

// A registered image: its pose and keypoints.
struct ImageRecord {
  uint32_t image_id = 0;
  std::string name;                                                  // file name relative to the image folder
  uint32_t camera_id = 0;
  Eigen::Quaterniond cam_from_world_rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d cam_from_world_translation = Eigen::Vector3d::Zero();
  std::vector<Point2D> points2d;

  Eigen::Matrix3d CamFromWorldRotation() const { return cam_from_world_rotation.toRotationMatrix(); }
  // Camera centre in world coordinates, -R^T t.
  Eigen::Vector3d ProjectionCenter() const;
  // Camera's optical axis (+z of the camera) in world coordinates.
  Eigen::Vector3d ViewingDirection() const;
  // World point to camera frame.
  Eigen::Vector3d CamFromWorld(const Eigen::Vector3d& point_world) const;
  // Sets the pose from a world-frame camera centre and rotation cam_from_world.
  void SetPose(const Eigen::Matrix3d& cam_from_world_rotation, const Eigen::Vector3d& center_world);
};

// A triangulated point.
struct Point3D {
  uint64_t point3d_id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Matrix<uint8_t, 3, 1> rgb = Eigen::Matrix<uint8_t, 3, 1>::Zero();
  double error = 0;                                      // mean reprojection error, pixels
  std::vector<std::pair<uint32_t, uint32_t>> track;      // (image_id, point2D index)
};

// A similarity transform x' = scale * R * x + t.
struct Sim3 {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d Apply(const Eigen::Vector3d& x) const { return scale * (rotation * x) + translation; }
  Sim3 Inverse() const;
};

struct Reconstruction {
  std::map<uint32_t, Camera> cameras;
  std::map<uint32_t, ImageRecord> images;
  std::map<uint64_t, Point3D> points3d;

  // Reads a model folder holding cameras/images/points3D as .bin (preferred) or .txt.
  // Throws UserError naming the folder when files are missing or malformed.
  static Reconstruction Read(const std::string& dir);
  static Reconstruction ReadText(const std::string& dir);
  static Reconstruction ReadBinary(const std::string& dir);
  // Writes the three files (atomically each) into an existing folder.
  void WriteText(const std::string& dir) const;
  void WriteBinary(const std::string& dir) const;

  // The image with this file name, or nullptr.
  const ImageRecord* FindImage(const std::string& name) const;
  // Pixel of a world point in an image and its camera-space depth (z); false if behind the camera.
  bool Project(const ImageRecord& image, const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel,
               double* depth = nullptr) const;
  // Applies a similarity to the world frame (cameras keep their intrinsics).
  void Transform(const Sim3& new_from_old);
  // Mean reprojection error over all observations (pixels).
  double MeanReprojectionError() const;
};

}  // namespace relight
