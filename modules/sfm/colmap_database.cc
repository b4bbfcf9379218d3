#include "sfm/colmap_database.h"

#include <sqlite3.h>

#include <cstring>

#include "core/error.h"

namespace relight {
namespace {

// COLMAP's pair id: image_id1 * kMaxNumImages + image_id2 with image_id1 < image_id2.
constexpr int64_t kMaxNumImages = 2147483647;

class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& path) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
      RELIGHT_USER_ERROR() << "COLMAP database '" << path << "' is not readable (" << sqlite3_errmsg(db)
                           << "); delete it and rerun the sfm stage";
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  bool Step() { return sqlite3_step(stmt_) == SQLITE_ROW; }
  sqlite3_stmt* get() { return stmt_; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace

ColmapDatabase::ColmapDatabase(const std::string& path) : path_(path) {
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    const std::string message = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    RELIGHT_USER_ERROR() << "cannot open COLMAP database '" << path << "': " << message
                         << "; COLMAP's feature extraction did not write it (see stage.log)";
  }
  sqlite3_busy_timeout(db_, 10000);
}

ColmapDatabase::~ColmapDatabase() { sqlite3_close(db_); }

std::map<int, DatabaseCamera> ColmapDatabase::ReadCameras() const {
  std::map<int, DatabaseCamera> cameras;
  Statement s(db_, "SELECT camera_id, model, width, height, params, prior_focal_length FROM cameras;", path_);
  while (s.Step()) {
    DatabaseCamera c;
    c.camera_id = sqlite3_column_int(s.get(), 0);
    c.model_id = sqlite3_column_int(s.get(), 1);
    c.width = static_cast<int>(sqlite3_column_int64(s.get(), 2));
    c.height = static_cast<int>(sqlite3_column_int64(s.get(), 3));
    const int bytes = sqlite3_column_bytes(s.get(), 4);
    c.params.resize(bytes / sizeof(double));
    if (bytes > 0) std::memcpy(c.params.data(), sqlite3_column_blob(s.get(), 4), c.params.size() * sizeof(double));
    c.prior_focal_length = sqlite3_column_int(s.get(), 5) != 0;
    cameras[c.camera_id] = c;
  }
  return cameras;
}

std::vector<DatabaseImage> ColmapDatabase::ReadImages(int min_inliers) const {
  std::vector<DatabaseImage> images;
  std::map<int, size_t> index;
  {
    Statement s(db_,
                "SELECT images.image_id, images.name, images.camera_id, IFNULL(keypoints.rows, 0) FROM images "
                "LEFT JOIN keypoints ON images.image_id = keypoints.image_id ORDER BY images.image_id;",
                path_);
    while (s.Step()) {
      DatabaseImage im;
      im.image_id = sqlite3_column_int(s.get(), 0);
      im.name = reinterpret_cast<const char*>(sqlite3_column_text(s.get(), 1));
      im.camera_id = sqlite3_column_int(s.get(), 2);
      im.num_keypoints = sqlite3_column_int(s.get(), 3);
      index[im.image_id] = images.size();
      images.push_back(im);
    }
  }
  Statement s(db_, "SELECT pair_id FROM two_view_geometries WHERE rows >= " + std::to_string(min_inliers) + ";", path_);
  while (s.Step()) {
    const int64_t pair_id = sqlite3_column_int64(s.get(), 0);
    const int id2 = static_cast<int>(pair_id % kMaxNumImages);
    const int id1 = static_cast<int>((pair_id - id2) / kMaxNumImages);
    for (int id : {id1, id2}) {
      auto it = index.find(id);
      if (it != index.end()) ++images[it->second].num_verified_partners;
    }
  }
  return images;
}

int ColmapDatabase::CountVerifiedPairs(int min_inliers) const {
  Statement s(db_, "SELECT COUNT(*) FROM two_view_geometries WHERE rows >= " + std::to_string(min_inliers) + ";",
              path_);
  return s.Step() ? sqlite3_column_int(s.get(), 0) : 0;
}

void ColmapDatabase::UpdateCamera(const DatabaseCamera& camera) {
  Statement s(db_, "UPDATE cameras SET params = ?, prior_focal_length = ? WHERE camera_id = ?;", path_);
  sqlite3_bind_blob(s.get(), 1, camera.params.data(), static_cast<int>(camera.params.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
  sqlite3_bind_int(s.get(), 2, camera.prior_focal_length ? 1 : 0);
  sqlite3_bind_int(s.get(), 3, camera.camera_id);
  if (sqlite3_step(s.get()) != SQLITE_DONE) {
    RELIGHT_USER_ERROR() << "cannot update camera " << camera.camera_id << " in COLMAP database '" << path_
                         << "': " << sqlite3_errmsg(db_);
  }
}

}  // namespace relight
