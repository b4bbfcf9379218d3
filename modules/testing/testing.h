// Test helpers shared by every module's tests: locations of the source tree,
// the built executables and the shared data, scratch folders and subprocesses.
#pragma once

#include <string>

#include "core/error.h"

namespace relight::testing {

// Root of the source checkout (RELIGHT_SOURCE_DIR, set by CTest).
std::string SourceDir();
// build/bin, where every executable lands (RELIGHT_BIN_DIR).
std::string BinDir();
// ../shared/data beside the checkout (RELIGHT_SHARED_DATA_DIR).
std::string SharedDataDir();
// True when `SharedDataDir()/relative` exists.
bool HasSharedData(const std::string& relative);

// A fresh folder under the system temp dir, removed on destruction unless
// RELIGHT_KEEP_TEST_DIRS=1 is set (then its path is printed).
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& relative) const { return path_ + "/" + relative; }

 private:
  std::string path_;
};

// Runs `command` through /bin/sh, capturing stdout and stderr together into
// `output` (if given). Returns the exit status (128+signal when killed).
int RunCommand(const std::string& command, std::string* output = nullptr);

// The message of the UserError `f` throws ("" when it throws none; any other exception fails the test).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}

}  // namespace relight::testing
