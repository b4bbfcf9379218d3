// Scratch data larger than memory should hold: an unnamed file in a folder,
// appended to while it is produced, then mapped read-only. The file has no
// name from the start (O_TMPFILE, or a name unlinked at once where the file
// system lacks it), so nothing is left behind however the process ends.
// Pages that were read and are not needed soon can be dropped from the
// process's resident set (DropPages); the kernel keeps them in its cache
// while memory allows and reads them back on the next access.
// Written by hand: a thin wrapper over open(2), write(2), mmap(2) and
// madvise(2) with the project's error messages; no packaged library does
// less than a whole storage engine.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace relight {

class ScratchFile {
 public:
  // Creates the file in `dir` (which must exist). `purpose` names the data in
  // error messages ("transport rows"). Throws UserError naming the folder.
  ScratchFile(const std::string& dir, std::string purpose);
  ~ScratchFile();
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  // Appends `bytes` bytes. Throws UserError naming the folder when the write
  // fails (a full disk, a file-size limit), with the size written so far.
  void Append(const void* data, size_t bytes);
  uint64_t size() const { return size_; }

  // Maps the whole file read-only; no Append afterwards. Returns the first
  // byte (nullptr for an empty file). Throws UserError when mmap fails.
  const char* Map();
  const char* data() const { return static_cast<const char*>(map_); }

  // Drops the pages holding bytes [begin, end) from the resident set (whole
  // pages, rounded outwards: data on a shared page is read back when touched).
  void DropPages(uint64_t begin, uint64_t end) const;

  const std::string& dir() const { return dir_; }

 private:
  std::string dir_, purpose_;
  int fd_ = -1;
  uint64_t size_ = 0;
  void* map_ = nullptr;
};

}  // namespace relight
