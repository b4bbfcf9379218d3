// SHA-256 content digests (OpenSSL), used for cache keys and input identity.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "core/fs.h"

namespace relight {

// Incremental SHA-256.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(const void* data, size_t size);
  void Update(std::string_view text) { Update(text.data(), text.size()); }
  // Lower-case hex digest (64 characters). The object cannot be updated afterwards.
  std::string HexDigest();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Hex SHA-256 of a string.
std::string Sha256Hex(std::string_view data);
// Hex SHA-256 of a file's bytes. Throws UserError when it cannot be read.
std::string FileSha256(const std::string& path);

// Content digests of files and folders, remembered across runs by
// (absolute path, size, modification time) in a small JSON file, so a large
// photo folder is hashed once, not at every `pipeline run`.
class DigestCache {
 public:
  // `cache_file` may be empty (no persistence).
  explicit DigestCache(std::string cache_file = "");
  // Digest of a file's bytes, or of a folder: the files `selection` takes from
  // it (ListFiles; sorted relative paths, each with its content digest; a file
  // that cannot be read counts by its size and time, so the stage reading it
  // reports it). Throws UserError when the path does not exist.
  std::string Digest(const std::string& path, const FileSelection& selection = {});
  // Writes the remembered digests (atomically). No-op without a cache file.
  void Save() const;

 private:
  std::string FileDigest(const std::string& path);

  std::string cache_file_;
  mutable std::mutex mutex_;
  // PathText(absolute path) -> (stamp, digest); the cache file is JSON, hence text keys.
  std::map<std::string, std::pair<std::string, std::string>> entries_;
  bool dirty_ = false;
};

}  // namespace relight
