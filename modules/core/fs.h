// File-system helpers with the project's durability rules: every output is
// written to a temporary name in the same folder and renamed into place, so a
// killed run or a full disk never leaves a half-written file under a final name.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace relight {

// Writes `data` to `path` atomically (temp file, fsync, rename). Throws
// UserError naming the path when the write fails (e.g. disk full); the previous
// content of `path`, if any, is left untouched.
void WriteFileAtomic(const std::string& path, std::string_view data);

// Reads a whole file. Throws UserError naming the path when it cannot.
std::string ReadFileToString(const std::string& path);

// For writers that insist on a path (image libraries, external tools): write to
// `temp_path()`, then `Commit()` renames it to the final path. Destroying an
// uncommitted AtomicFile removes the temporary. The temporary keeps the final
// extension, so format detection by extension still works.
class AtomicFile {
 public:
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  const std::string& temp_path() const { return temp_path_; }
  const std::string& final_path() const { return final_path_; }
  // Renames the temporary to the final path. Throws UserError if it is missing.
  void Commit();

 private:
  std::string final_path_;
  std::string temp_path_;
  bool committed_ = false;
};

// Marker that every temporary name contains.
inline constexpr std::string_view kTempMarker = ".relight-tmp-";
// Removes leftover temporaries (from killed runs) below `dir`, recursively.
void RemoveTempFiles(const std::string& dir);
// Creates a folder and its parents; throws UserError naming it on failure.
void EnsureDir(const std::string& dir);
// Moves a folder into place atomically (rename); removes `to` first if it exists.
void ReplaceDir(const std::string& from, const std::string& to);
// Free space in bytes on the file system holding `path` (0 when unknown).
unsigned long long FreeBytes(const std::string& path);
// Joins path components.
std::string JoinPath(const std::string& a, const std::string& b);

// Which files of a folder a reader takes: regular files (or links to them)
// whose names do not start with '.', outside hidden sub-folders, below
// sub-folders only when `recursive`, and, when `extensions` is not empty,
// only those whose lower-case extension is listed. A stage that reads a
// folder declares its selection on the option (OptionField::Reads), so the
// cache key digests exactly the files the stage reads.
struct FileSelection {
  bool recursive = true;
  std::vector<std::string> extensions;  // lower case with the dot (".jpg"); empty: every file
};
// The selected files below `dir`, sorted. Sub-folders that cannot be opened
// are skipped; throws UserError naming `dir` when it cannot be listed.
std::vector<std::string> ListFiles(const std::string& dir, const FileSelection& selection);

}  // namespace relight
