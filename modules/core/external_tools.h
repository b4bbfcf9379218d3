// External executables the stages run, found and started the same way by every module.
#pragma once

#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "core/process.h"

namespace relight {

// The COLMAP executable: $RELIGHT_COLMAP if set, else `colmap` from PATH.
inline std::string ColmapExecutable() {
  const char* env = std::getenv("RELIGHT_COLMAP");
  return env != nullptr && *env != '\0' ? env : "colmap";
}

// Runs `colmap <args...>` (core/process.h: it dies with the stage); every output line goes to the stage log
// file and to `on_line` (may be empty). Without a display (QT_QPA_PLATFORM=offscreen) and with OpenMP threads
// that sleep while they wait (OMP_WAIT_POLICY=passive: COLMAP's spin by default and starve a shared machine),
// unless the environment says otherwise. Does not throw: callers check the result and the outputs (COLMAP
// often exits 0 without writing anything).
ProcessResult RunColmapProcess(const std::vector<std::string>& args,
                               const std::function<void(const std::string&)>& on_line = {});

}  // namespace relight
