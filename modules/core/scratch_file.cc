#include "core/scratch_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "core/error.h"

namespace relight {
namespace {

std::string MiB(uint64_t bytes) { return std::to_string((bytes + (1u << 19)) >> 20) + " MiB"; }

}  // namespace

ScratchFile::ScratchFile(const std::string& dir, std::string purpose) : dir_(dir), purpose_(std::move(purpose)) {
  fd_ = ::open(dir_.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd_ < 0 && (errno == EOPNOTSUPP || errno == EISDIR || errno == EINVAL)) {
    // File systems without O_TMPFILE (some network ones): a name removed at once.
    std::string name = dir_ + "/.scratch-XXXXXX";
    fd_ = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd_ >= 0) ::unlink(name.c_str());
  }
  if (fd_ < 0) {
    const int err = errno;
    RELIGHT_USER_ERROR() << "cannot create a scratch file for the " << purpose_ << " in '" << dir_
                         << "': " << std::strerror(err) << "; check the folder exists and is writable";
  }
}

ScratchFile::~ScratchFile() {
  if (map_ != nullptr) ::munmap(map_, size_);
  if (fd_ >= 0) ::close(fd_);
}

void ScratchFile::Append(const void* data, size_t bytes) {
  RELIGHT_CHECK(map_ == nullptr) << "ScratchFile::Append after Map";
  const char* p = static_cast<const char*>(data);
  size_t done = 0;
  while (done < bytes) {
    const ssize_t n = ::write(fd_, p + done, bytes - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      const char* hint = err == ENOSPC || err == EDQUOT
                             ? "the disk is full: free space there (the file needs about as much again as "
                               "written so far, or more) and rerun; finished stages are kept"
                         : err == EFBIG ? "the file-size limit was reached (ulimit -f): raise it and rerun"
                                        : "check the folder is writable";
      RELIGHT_USER_ERROR() << "cannot write the " << purpose_ << " to a scratch file in '" << dir_ << "' after "
                           << MiB(size_ + done) << ": " << std::strerror(err) << "; " << hint;
    }
    done += static_cast<size_t>(n);
  }
  size_ += bytes;
}

const char* ScratchFile::Map() {
  if (map_ != nullptr || size_ == 0) return data();
  void* m = ::mmap(nullptr, size_, PROT_READ, MAP_SHARED, fd_, 0);
  if (m == MAP_FAILED) {
    const int err = errno;
    RELIGHT_USER_ERROR() << "cannot map the " << purpose_ << " (" << MiB(size_) << ", a scratch file in '" << dir_
                         << "'): " << std::strerror(err);
  }
  map_ = m;
  return data();
}

void ScratchFile::DropPages(uint64_t begin, uint64_t end) const {
  if (map_ == nullptr || begin >= end) return;
  static const uint64_t page = static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
  const uint64_t first = begin / page * page;
  const uint64_t last = std::min<uint64_t>(size_, (end + page - 1) / page * page);
  // Advice only: a failure leaves the pages resident, which costs memory, not correctness.
  ::madvise(static_cast<char*>(map_) + first, last - first, MADV_DONTNEED);
}

}  // namespace relight
