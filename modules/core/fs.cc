#include "core/fs.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace relight {
namespace fs = std::filesystem;

namespace {
std::string MakeTempPath(const std::string& final_path) {
  static std::atomic<int> counter{0};
  const fs::path p(final_path);
  std::string name = p.stem().string() + std::string(kTempMarker) + std::to_string(::getpid()) + "-" +
                     std::to_string(counter++) + p.extension().string();
  return (p.parent_path() / name).string();
}

[[noreturn]] void ThrowWriteError(const std::string& path, int err) {
  std::string hint = err == ENOSPC   ? "the disk is full; free space and rerun (finished stages are kept)"
                     : err == EACCES ? "permission denied; choose a writable workspace"
                                     : "check the folder exists and is writable";
  throw UserError("cannot write '" + path + "': " + std::strerror(err) + "; " + hint);
}
}  // namespace

void WriteFileAtomic(const std::string& path, std::string_view data) {
  const std::string tmp = MakeTempPath(path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) ThrowWriteError(path, errno);
  size_t written = 0;
  while (written < data.size()) {
    const ssize_t n = ::write(fd, data.data() + written, data.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      ThrowWriteError(path, err);
    }
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    ThrowWriteError(path, err);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    ThrowWriteError(path, err);
  }
}

std::string ReadFileToString(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) RELIGHT_USER_ERROR() << "cannot read '" << path << "': it does not exist or is not readable";
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

AtomicFile::AtomicFile(std::string final_path)
    : final_path_(std::move(final_path)), temp_path_(MakeTempPath(final_path_)) {}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_path_, ec);
  }
}

void AtomicFile::Commit() {
  if (!fs::exists(temp_path_)) {
    RELIGHT_USER_ERROR() << "writing '" << final_path_ << "' produced no file (disk full or write error?)";
  }
  // Flush file data to disk before the rename makes it visible.
  const int fd = ::open(temp_path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) ThrowWriteError(final_path_, errno);
  committed_ = true;
}

void RemoveTempFiles(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<fs::path> doomed;
  for (auto it = fs::recursive_directory_iterator(dir, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (ec) break;
    if (it->path().filename().string().find(kTempMarker) != std::string::npos) doomed.push_back(it->path());
  }
  for (const auto& p : doomed) fs::remove_all(p, ec);
}

void EnsureDir(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    RELIGHT_USER_ERROR() << "cannot create folder '" << dir << "': " << ec.message()
                         << "; choose a writable location";
  }
}

void ReplaceDir(const std::string& from, const std::string& to) {
  std::error_code ec;
  if (fs::exists(to)) {
    const std::string old = MakeTempPath(to);
    fs::rename(to, old, ec);
    if (ec) RELIGHT_USER_ERROR() << "cannot replace '" << to << "': " << ec.message();
    fs::rename(from, to, ec);
    fs::remove_all(old);
  } else {
    fs::rename(from, to, ec);
  }
  if (ec) RELIGHT_USER_ERROR() << "cannot move '" << from << "' to '" << to << "': " << ec.message();
}

unsigned long long FreeBytes(const std::string& path) {
  std::error_code ec;
  const auto info = fs::space(path, ec);
  return ec ? 0ULL : static_cast<unsigned long long>(info.available);
}

std::string JoinPath(const std::string& a, const std::string& b) { return (fs::path(a) / b).string(); }

std::vector<std::string> ListFiles(const std::string& dir, const FileSelection& selection) {
  auto selected = [&](const fs::directory_entry& e) {
    std::error_code ec;
    if (!e.is_regular_file(ec)) return false;  // includes entries that vanished or cannot be stat'ed
    if (selection.extensions.empty()) return true;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return std::find(selection.extensions.begin(), selection.extensions.end(), ext) != selection.extensions.end();
  };
  auto fail = [&](const std::error_code& ec) {
    RELIGHT_USER_ERROR() << "cannot list folder '" << dir << "': " << ec.message()
                         << "; check that it exists and is readable";
  };
  std::vector<std::string> files;
  std::error_code ec;
  const auto options = fs::directory_options::skip_permission_denied;
  if (selection.recursive) {
    fs::recursive_directory_iterator it(dir, options, ec), end;
    if (ec) fail(ec);
    for (; it != end; it.increment(ec)) {
      if (ec) fail(ec);
      const std::string name = it->path().filename().string();
      if (!name.empty() && name[0] == '.') {
        std::error_code dir_ec;
        if (it->is_directory(dir_ec)) it.disable_recursion_pending();
        continue;
      }
      if (selected(*it)) files.push_back(it->path().string());
    }
    if (ec) fail(ec);
  } else {
    fs::directory_iterator it(dir, options, ec), end;
    if (ec) fail(ec);
    for (; it != end; it.increment(ec)) {
      if (ec) fail(ec);
      const std::string name = it->path().filename().string();
      if (!name.empty() && name[0] == '.') continue;
      if (selected(*it)) files.push_back(it->path().string());
    }
    if (ec) fail(ec);
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace relight
