// SHA-256 content digests (OpenSSL), used for cache keys and input identity.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

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
  // Digest of a file's bytes, or of a folder: every regular file below it
  // (sorted relative paths, each with its content digest). Hidden files are
  // ignored. Throws UserError when the path does not exist.
  std::string Digest(const std::string& path);
  // Writes the remembered digests (atomically). No-op without a cache file.
  void Save() const;

 private:
  std::string FileDigest(const std::string& path);

  std::string cache_file_;
  mutable std::mutex mutex_;
  std::map<std::string, std::pair<std::string, std::string>> entries_;  // path -> (stamp, digest)
  bool dirty_ = false;
};

}  // namespace relight
