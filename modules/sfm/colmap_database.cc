#include "sfm/colmap_database.h"

#include <sqlite3.h>

#include <cmath>
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
  // Runs a statement that returns no rows; throws naming `what` on failure.
  void Done(sqlite3* db, const std::string& path, const std::string& what) {
    if (sqlite3_step(stmt_) != SQLITE_DONE) {
      RELIGHT_USER_ERROR() << "cannot " << what << " in COLMAP database '" << path << "': " << sqlite3_errmsg(db);
    }
  }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

void PairFromId(int64_t pair_id, int* id1, int* id2) {
  *id2 = static_cast<int>(pair_id % kMaxNumImages);
  *id1 = static_cast<int>((pair_id - *id2) / kMaxNumImages);
}

// A rows x 2 uint32 blob of keypoint index pairs.
std::vector<std::array<uint32_t, 2>> ReadMatchBlob(sqlite3_stmt* s, int rows_col, int cols_col, int data_col) {
  const int rows = sqlite3_column_int(s, rows_col), cols = sqlite3_column_int(s, cols_col);
  std::vector<std::array<uint32_t, 2>> out;
  if (rows <= 0 || cols != 2 || sqlite3_column_bytes(s, data_col) != rows * 2 * int(sizeof(uint32_t))) return out;
  out.resize(rows);
  std::memcpy(out.data(), sqlite3_column_blob(s, data_col), size_t(rows) * 2 * sizeof(uint32_t));
  return out;
}

Eigen::Matrix3d ReadMatrixBlob(sqlite3_stmt* s, int col) {
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> m = Eigen::Matrix3d::Zero();
  if (sqlite3_column_bytes(s, col) == 9 * int(sizeof(double))) std::memcpy(m.data(), sqlite3_column_blob(s, col), 72);
  return m;
}

}  // namespace

int64_t ColmapPairId(int image_id1, int image_id2) {
  if (image_id1 > image_id2) std::swap(image_id1, image_id2);
  return int64_t(image_id1) * kMaxNumImages + image_id2;
}

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
    int id1 = 0, id2 = 0;
    PairFromId(sqlite3_column_int64(s.get(), 0), &id1, &id2);
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

void ColmapDatabase::CanonicalizeIds() {
  {
    Statement m(db_, "SELECT (SELECT COUNT(*) FROM matches) + (SELECT COUNT(*) FROM two_view_geometries);", path_);
    RELIGHT_CHECK(m.Step() && sqlite3_column_int(m.get(), 0) == 0) << "canonicalise ids before matching";
  }
  std::vector<std::pair<std::string, std::pair<int, int>>> images;  // name -> (image id, camera id)
  {
    Statement s(db_, "SELECT name, image_id, camera_id FROM images ORDER BY name;", path_);
    while (s.Step()) {
      images.push_back({reinterpret_cast<const char*>(sqlite3_column_text(s.get(), 0)),
                        {sqlite3_column_int(s.get(), 1), sqlite3_column_int(s.get(), 2)}});
    }
  }
  std::map<int, int> new_camera;  // old camera id -> new
  for (const auto& [name, ids] : images) new_camera.emplace(ids.second, static_cast<int>(new_camera.size()) + 1);
  // Move every id out of the way (ids are below 2^31 - 1; the offset keeps them valid), then to its new value.
  const int64_t kOffset = 1000000000;
  auto exec = [&](const std::string& sql, const std::string& what) { Statement(db_, sql, path_).Done(db_, path_, what); };
  exec("BEGIN TRANSACTION;", "begin a transaction");
  for (const char* table : {"images", "keypoints", "descriptors"}) {
    exec("UPDATE " + std::string(table) + " SET image_id = image_id + " + std::to_string(kOffset) + ";",
         "renumber images");
  }
  exec("UPDATE cameras SET camera_id = camera_id + " + std::to_string(kOffset) + ";", "renumber cameras");
  exec("UPDATE images SET camera_id = camera_id + " + std::to_string(kOffset) + ";", "renumber cameras");
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string from = std::to_string(images[k].second.first + kOffset), to = std::to_string(k + 1);
    for (const char* table : {"images", "keypoints", "descriptors"}) {
      exec("UPDATE " + std::string(table) + " SET image_id = " + to + " WHERE image_id = " + from + ";",
           "renumber images");
    }
  }
  for (const auto& [old_id, new_id] : new_camera) {
    const std::string from = std::to_string(old_id + kOffset), to = std::to_string(new_id);
    exec("UPDATE cameras SET camera_id = " + to + " WHERE camera_id = " + from + ";", "renumber cameras");
    exec("UPDATE images SET camera_id = " + to + " WHERE camera_id = " + from + ";", "renumber cameras");
  }
  exec("COMMIT;", "commit the renumbering");
}

void ColmapDatabase::UpdateCamera(const DatabaseCamera& camera) {
  Statement s(db_,
              "UPDATE cameras SET model = ?, width = ?, height = ?, params = ?, prior_focal_length = ? "
              "WHERE camera_id = ?;",
              path_);
  sqlite3_bind_int(s.get(), 1, camera.model_id);
  sqlite3_bind_int64(s.get(), 2, camera.width);
  sqlite3_bind_int64(s.get(), 3, camera.height);
  sqlite3_bind_blob(s.get(), 4, camera.params.data(), static_cast<int>(camera.params.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
  sqlite3_bind_int(s.get(), 5, camera.prior_focal_length ? 1 : 0);
  sqlite3_bind_int(s.get(), 6, camera.camera_id);
  if (sqlite3_step(s.get()) != SQLITE_DONE) {
    RELIGHT_USER_ERROR() << "cannot update camera " << camera.camera_id << " in COLMAP database '" << path_
                         << "': " << sqlite3_errmsg(db_);
  }
}

std::vector<Eigen::Vector2d> ColmapDatabase::ReadKeypoints(int image_id) const {
  Statement s(db_, "SELECT rows, cols, data FROM keypoints WHERE image_id = " + std::to_string(image_id) + ";", path_);
  std::vector<Eigen::Vector2d> points;
  if (!s.Step()) return points;
  const int rows = sqlite3_column_int(s.get(), 0), cols = sqlite3_column_int(s.get(), 1);
  if (rows <= 0 || cols < 2 || sqlite3_column_bytes(s.get(), 2) != rows * cols * int(sizeof(float))) return points;
  std::vector<float> data(size_t(rows) * cols);
  std::memcpy(data.data(), sqlite3_column_blob(s.get(), 2), data.size() * sizeof(float));
  points.reserve(rows);
  for (int r = 0; r < rows; ++r) points.emplace_back(data[size_t(r) * cols], data[size_t(r) * cols + 1]);
  return points;
}

std::vector<uint8_t> ColmapDatabase::ReadDescriptors(int image_id, int* rows, int* cols) const {
  Statement s(db_, "SELECT rows, cols, data FROM descriptors WHERE image_id = " + std::to_string(image_id) + ";",
              path_);
  std::vector<uint8_t> data;
  *rows = 0;
  *cols = 0;
  if (!s.Step()) return data;
  const int r = sqlite3_column_int(s.get(), 0), c = sqlite3_column_int(s.get(), 1);
  if (r <= 0 || c <= 0 || sqlite3_column_bytes(s.get(), 2) != r * c) return data;
  data.resize(size_t(r) * c);
  std::memcpy(data.data(), sqlite3_column_blob(s.get(), 2), data.size());
  *rows = r;
  *cols = c;
  return data;
}

void ColmapDatabase::AppendFeatures(int image_id, const std::vector<float>& keypoints,
                                    const std::vector<uint8_t>& descriptors) {
  const size_t n = descriptors.size() / 128;
  RELIGHT_CHECK(descriptors.size() == n * 128 && keypoints.size() == n * 6) << "AppendFeatures: inconsistent sizes";
  if (n == 0) return;
  std::vector<float> old_keypoints;
  int old_rows = 0, keypoint_cols = 6;
  {
    Statement s(db_, "SELECT rows, cols, data FROM keypoints WHERE image_id = " + std::to_string(image_id) + ";",
                path_);
    if (s.Step()) {
      old_rows = sqlite3_column_int(s.get(), 0);
      keypoint_cols = sqlite3_column_int(s.get(), 1);
      if (old_rows < 0 || (keypoint_cols != 4 && keypoint_cols != 6) ||
          sqlite3_column_bytes(s.get(), 2) != old_rows * keypoint_cols * int(sizeof(float))) {
        RELIGHT_USER_ERROR() << "COLMAP database '" << path_ << "' has malformed keypoints for image " << image_id
                             << "; delete it and rerun the sfm stage";
      }
      old_keypoints.resize(size_t(old_rows) * keypoint_cols);
      if (!old_keypoints.empty()) {
        std::memcpy(old_keypoints.data(), sqlite3_column_blob(s.get(), 2), old_keypoints.size() * sizeof(float));
      }
    }
  }
  int descriptor_rows = 0, descriptor_cols = 0;
  std::vector<uint8_t> all_descriptors = ReadDescriptors(image_id, &descriptor_rows, &descriptor_cols);
  if (descriptor_rows != old_rows || (descriptor_rows > 0 && descriptor_cols != 128)) {
    RELIGHT_USER_ERROR() << "COLMAP database '" << path_ << "' has " << old_rows << " keypoints but " << descriptor_rows
                         << " descriptors of " << descriptor_cols << " bytes for image " << image_id
                         << "; delete it and rerun the sfm stage";
  }
  std::vector<float> all_keypoints = std::move(old_keypoints);
  for (size_t i = 0; i < n; ++i) {
    const float* k = &keypoints[i * 6];
    if (keypoint_cols == 6) {
      all_keypoints.insert(all_keypoints.end(), k, k + 6);
    } else {
      all_keypoints.insert(all_keypoints.end(), {k[0], k[1], std::sqrt(std::abs(k[2] * k[5] - k[3] * k[4])), 0.0f});
    }
  }
  all_descriptors.insert(all_descriptors.end(), descriptors.begin(), descriptors.end());
  const int rows = old_rows + static_cast<int>(n);
  auto exec = [&](const std::string& sql, const std::string& what) { Statement(db_, sql, path_).Done(db_, path_, what); };
  exec("BEGIN TRANSACTION;", "begin a transaction");
  for (const char* table : {"keypoints", "descriptors"}) {
    exec("DELETE FROM " + std::string(table) + " WHERE image_id = " + std::to_string(image_id) + ";",
         "replace features");
  }
  {
    Statement s(db_, "INSERT INTO keypoints (image_id, rows, cols, data) VALUES (?, ?, ?, ?);", path_);
    sqlite3_bind_int(s.get(), 1, image_id);
    sqlite3_bind_int(s.get(), 2, rows);
    sqlite3_bind_int(s.get(), 3, keypoint_cols);
    sqlite3_bind_blob(s.get(), 4, all_keypoints.data(), int(all_keypoints.size() * sizeof(float)), SQLITE_TRANSIENT);
    s.Done(db_, path_, "write keypoints");
  }
  {
    Statement s(db_, "INSERT INTO descriptors (image_id, rows, cols, data) VALUES (?, ?, 128, ?);", path_);
    sqlite3_bind_int(s.get(), 1, image_id);
    sqlite3_bind_int(s.get(), 2, rows);
    sqlite3_bind_blob(s.get(), 3, all_descriptors.data(), int(all_descriptors.size()), SQLITE_TRANSIENT);
    s.Done(db_, path_, "write descriptors");
  }
  exec("COMMIT;", "commit the features");
}

void ColmapDatabase::ReplaceMatches(const std::vector<DatabaseMatches>& matches) {
  Statement(db_, "BEGIN TRANSACTION;", path_).Done(db_, path_, "begin a transaction");
  Statement(db_, "DELETE FROM matches;", path_).Done(db_, path_, "clear the matches");
  for (const auto& m : matches) {
    RELIGHT_CHECK_LT(m.image_id1, m.image_id2);
    Statement s(db_, "INSERT INTO matches (pair_id, rows, cols, data) VALUES (?, ?, 2, ?);", path_);
    sqlite3_bind_int64(s.get(), 1, ColmapPairId(m.image_id1, m.image_id2));
    sqlite3_bind_int(s.get(), 2, static_cast<int>(m.matches.size()));
    sqlite3_bind_blob(s.get(), 3, m.matches.data(), int(m.matches.size() * 2 * sizeof(uint32_t)), SQLITE_TRANSIENT);
    s.Done(db_, path_, "write matches");
  }
  Statement(db_, "COMMIT;", path_).Done(db_, path_, "commit the matches");
}

std::vector<DatabaseMatches> ColmapDatabase::ReadAllMatches() const {
  Statement s(db_, "SELECT pair_id, rows, cols, data FROM matches ORDER BY pair_id;", path_);
  std::vector<DatabaseMatches> out;
  while (s.Step()) {
    DatabaseMatches m;
    PairFromId(sqlite3_column_int64(s.get(), 0), &m.image_id1, &m.image_id2);
    m.matches = ReadMatchBlob(s.get(), 1, 2, 3);
    if (!m.matches.empty()) out.push_back(std::move(m));
  }
  return out;
}

std::vector<DatabaseTwoViewGeometry> ColmapDatabase::ReadTwoViewGeometries() const {
  Statement s(db_, "SELECT pair_id, rows, cols, data, config, F, H FROM two_view_geometries ORDER BY pair_id;", path_);
  std::vector<DatabaseTwoViewGeometry> out;
  while (s.Step()) {
    DatabaseTwoViewGeometry g;
    PairFromId(sqlite3_column_int64(s.get(), 0), &g.image_id1, &g.image_id2);
    g.inlier_matches = ReadMatchBlob(s.get(), 1, 2, 3);
    g.config = sqlite3_column_int(s.get(), 4);
    g.F = ReadMatrixBlob(s.get(), 5);
    g.H = ReadMatrixBlob(s.get(), 6);
    out.push_back(std::move(g));
  }
  return out;
}

void ColmapDatabase::ReplaceTwoViewGeometries(const std::vector<DatabaseTwoViewGeometry>& geometries) {
  Statement(db_, "BEGIN TRANSACTION;", path_).Done(db_, path_, "begin a transaction");
  Statement(db_, "DELETE FROM two_view_geometries;", path_).Done(db_, path_, "clear the verified geometries");
  for (const auto& g : geometries) {
    RELIGHT_CHECK_LT(g.image_id1, g.image_id2);
    Statement s(db_,
                "INSERT INTO two_view_geometries (pair_id, rows, cols, data, config, F, E, H) "
                "VALUES (?, ?, 2, ?, ?, ?, ?, ?);",
                path_);
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> f = g.F, h = g.H, e = Eigen::Matrix3d::Zero();
    sqlite3_bind_int64(s.get(), 1, ColmapPairId(g.image_id1, g.image_id2));
    sqlite3_bind_int(s.get(), 2, static_cast<int>(g.inlier_matches.size()));
    sqlite3_bind_blob(s.get(), 3, g.inlier_matches.data(), int(g.inlier_matches.size() * 2 * sizeof(uint32_t)),
                      SQLITE_TRANSIENT);
    sqlite3_bind_int(s.get(), 4, g.config);
    sqlite3_bind_blob(s.get(), 5, f.data(), 72, SQLITE_TRANSIENT);
    sqlite3_bind_blob(s.get(), 6, e.data(), 72, SQLITE_TRANSIENT);
    sqlite3_bind_blob(s.get(), 7, h.data(), 72, SQLITE_TRANSIENT);
    s.Done(db_, path_, "write a verified geometry");
  }
  Statement(db_, "COMMIT;", path_).Done(db_, path_, "commit the verified geometries");
}

}  // namespace relight
