// Reading and adjusting a COLMAP 3.8 feature database (SQLite, schema in
// COLMAP's `src/base/database.cc`): camera priors before mapping, and the
// per-photo diagnostics (features, verified matches) that explain why a photo
// did not register.
#pragma once

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
  // Overwrites a camera's parameters and its prior_focal_length flag.
  void UpdateCamera(const DatabaseCamera& camera);

 private:
  std::string path_;
  ::sqlite3* db_ = nullptr;
};

}  // namespace relight
