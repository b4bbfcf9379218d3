// External executables the stages run, found the same way by every module.
#pragma once

#include <cstdlib>
#include <string>

namespace relight {

// The COLMAP executable: $RELIGHT_COLMAP if set, else `colmap` from PATH.
inline std::string ColmapExecutable() {
  const char* env = std::getenv("RELIGHT_COLMAP");
  return env != nullptr && *env != '\0' ? env : "colmap";
}

}  // namespace relight
