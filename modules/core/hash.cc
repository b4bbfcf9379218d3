#include "core/hash.h"

#include <openssl/evp.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/path_text.h"

namespace relight {
namespace fs = std::filesystem;

struct Sha256::Impl {
  EVP_MD_CTX* ctx = nullptr;
};

Sha256::Sha256() : impl_(new Impl) {
  impl_->ctx = EVP_MD_CTX_new();
  RELIGHT_CHECK(impl_->ctx != nullptr);
  RELIGHT_CHECK(EVP_DigestInit_ex(impl_->ctx, EVP_sha256(), nullptr) == 1);
}

Sha256::~Sha256() { EVP_MD_CTX_free(impl_->ctx); }

void Sha256::Update(const void* data, size_t size) {
  RELIGHT_CHECK(EVP_DigestUpdate(impl_->ctx, data, size) == 1);
}

std::string Sha256::HexDigest() {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  RELIGHT_CHECK(EVP_DigestFinal_ex(impl_->ctx, digest, &length) == 1);
  static const char* kHex = "0123456789abcdef";
  std::string out;
  out.reserve(2 * length);
  for (unsigned int i = 0; i < length; ++i) {
    out.push_back(kHex[digest[i] >> 4]);
    out.push_back(kHex[digest[i] & 15]);
  }
  return out;
}

std::string Sha256Hex(std::string_view data) {
  Sha256 h;
  h.Update(data);
  return h.HexDigest();
}

std::string FileSha256(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) RELIGHT_USER_ERROR() << "cannot read '" << path << "' to compute its digest; check that it exists";
  Sha256 h;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    h.Update(buffer.data(), static_cast<size_t>(in.gcount()));
  }
  if (in.bad()) RELIGHT_USER_ERROR() << "read error on '" << path << "'";
  return h.HexDigest();
}

DigestCache::DigestCache(std::string cache_file) : cache_file_(std::move(cache_file)) {
  if (cache_file_.empty() || !fs::exists(cache_file_)) return;
  try {
    const Json j = ReadJsonFile(cache_file_);
    for (const auto& [path, entry] : j.items()) {
      entries_[path] = {entry.at("stamp").get<std::string>(), entry.at("sha256").get<std::string>()};
    }
  } catch (const std::exception&) {
    entries_.clear();  // a damaged cache is only a lost optimisation
  }
}

std::string DigestCache::FileDigest(const std::string& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  const auto mtime = fs::last_write_time(path, ec).time_since_epoch().count();
  const std::string stamp = std::to_string(size) + ":" + std::to_string(mtime);
  const std::string key = PathText(path);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second.first == stamp) return it->second.second;
  }
  const std::string digest = FileSha256(path);
  std::lock_guard<std::mutex> lock(mutex_);
  entries_[key] = {stamp, digest};
  dirty_ = true;
  return digest;
}

std::string DigestCache::Digest(const std::string& path_in, const FileSelection& selection) {
  std::error_code ec;
  const std::string path = fs::absolute(path_in, ec).lexically_normal().string();
  if (fs::is_regular_file(path, ec)) return FileDigest(path);
  if (!fs::is_directory(path, ec)) {
    RELIGHT_USER_ERROR() << "input '" << path_in << "' does not exist; fix the path in the config";
  }
  Sha256 h;
  for (const auto& file : ListFiles(path, selection)) {
    std::string digest;
    try {
      digest = FileDigest(file);
    } catch (const UserError&) {  // unreadable: the stage skips or reports it
      const auto size = fs::file_size(file, ec);
      digest = "unreadable:" + std::to_string(ec ? 0 : size) + ":" +
               std::to_string(fs::last_write_time(file, ec).time_since_epoch().count());
    }
    h.Update(fs::path(file).lexically_relative(path).generic_string());
    h.Update("\n");
    h.Update(digest);
    h.Update("\n");
  }
  return h.HexDigest();
}

void DigestCache::Save() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (cache_file_.empty() || !dirty_) return;
  // Only remember digests inside an existing workspace (`status` must not create one).
  if (!fs::is_directory(fs::path(cache_file_).parent_path())) return;
  Json j = Json::object();
  for (const auto& [path, entry] : entries_) j[path] = {{"stamp", entry.first}, {"sha256", entry.second}};
  WriteJsonAtomic(cache_file_, j);
}

}  // namespace relight
