// Reading and adjusting a COLMAP 3.8 feature database (SQLite, schema in
// COLMAP's `src/base/database.cc`): camera priors before mapping, keypoints
// and putative matches for our own geometric verification, the verified
// geometries that the mapper reads, and the per-photo diagnostics (features,
// verified matches) that explain why a photo did not register.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

struct sqlite3;

namespace relight {

// A camera row of the database.
struct DatabaseCamera {
  int camera_id = 0;
  int model_id = 0;  // COLMAP model id (Camera::ModelId)
  int width = 0;
  int height = 0;
  std::vector<double> params;  // COLMAP parameter order
  bool prior_focal_length = false;
};

// An image row plus its feature and match statistics.
struct DatabaseImage {
  int image_id = 0;
  std::string name;  // relative to the image folder COLMAP was given
  int camera_id = 0;
  int num_keypoints = 0;
  int num_verified_partners = 0;  // other photos with geometrically verified matches
};

// The putative matches of one image pair: keypoint indices into each image.
struct DatabaseMatches {
  int image_id1 = 0;  // image_id1 < image_id2 (COLMAP's pair order)
  int image_id2 = 0;
  std::vector<std::array<uint32_t, 2>> matches;
};

// A verified two-view geometry as the mapper reads it.
struct DatabaseTwoViewGeometry {
  int image_id1 = 0;  // image_id1 < image_id2
  int image_id2 = 0;
  int config = 0;     // COLMAP's TwoViewGeometry::ConfigurationType (3: uncalibrated, 6: planar or panoramic)
  std::vector<std::array<uint32_t, 2>> inlier_matches;
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();  // x2^T F x1 = 0 in pixels (image_id1 -> image_id2)
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();  // x2 ~ H x1
};

// COLMAP's pair id: image_id1 * 2^31 - 1 + image_id2 with image_id1 < image_id2.
int64_t ColmapPairId(int image_id1, int image_id2);

// An open COLMAP database (closed on destruction).
class ColmapDatabase {
 public:
  // Opens an existing database; throws UserError naming the file when it cannot.
  explicit ColmapDatabase(const std::string& path);
  ~ColmapDatabase();
  ColmapDatabase(const ColmapDatabase&) = delete;
  ColmapDatabase& operator=(const ColmapDatabase&) = delete;

  std::map<int, DatabaseCamera> ReadCameras() const;
  // Images with keypoint counts and verified partners (pairs with at least `min_inliers` inliers).
  std::vector<DatabaseImage> ReadImages(int min_inliers = 15) const;
  // Number of geometrically verified image pairs with at least `min_inliers` inliers.
  int CountVerifiedPairs(int min_inliers = 15) const;
  // Renumbers images 1..n in name order and cameras in the order of their first image, in every table that
  // holds them (images, cameras, keypoints, descriptors; matches and verified pairs must be empty). COLMAP's
  // multi-threaded feature extraction numbers images in the order they finish, and the mapper's choices
  // depend on the numbers: with this the same photos give the same database.
  void CanonicalizeIds();
  // Overwrites a camera's model, size, parameters and prior_focal_length flag.
  void UpdateCamera(const DatabaseCamera& camera);
  // Keypoint positions of an image (COLMAP's convention: the top-left pixel's centre is (0.5, 0.5)).
  std::vector<Eigen::Vector2d> ReadKeypoints(int image_id) const;
  // SIFT descriptors of an image as stored (rows x cols bytes, row-major); empty when it has none.
  std::vector<uint8_t> ReadDescriptors(int image_id, int* rows, int* cols) const;
  // Appends features to an image's keypoints and descriptors (one transaction): `keypoints` holds 6 floats per
  // feature (x, y, a11, a12, a21, a22, COLMAP's SIFT layout; an image stored with 4 columns gets x, y, scale,
  // orientation 0), `descriptors` 128 bytes per feature.
  void AppendFeatures(int image_id, const std::vector<float>& keypoints, const std::vector<uint8_t>& descriptors);
  // Every pair's putative matches (the `matches` table).
  std::vector<DatabaseMatches> ReadAllMatches() const;
  // Replaces the `matches` table by `matches` (one transaction).
  void ReplaceMatches(const std::vector<DatabaseMatches>& matches);
  // Every verified geometry (the `two_view_geometries` table).
  std::vector<DatabaseTwoViewGeometry> ReadTwoViewGeometries() const;
  // Replaces the `two_view_geometries` table by `geometries` (one transaction).
  void ReplaceTwoViewGeometries(const std::vector<DatabaseTwoViewGeometry>& geometries);

 private:
  std::string path_;
  ::sqlite3* db_ = nullptr;
};

}  // namespace relight
