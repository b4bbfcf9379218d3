#include "sfm/colmap_command.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

#include "core/error.h"
#include "core/log.h"
#include "core/options.h"

namespace relight {

ColmapCommand& ColmapCommand::Arg(const std::string& key, const std::string& value) {
  args.emplace_back(key, value);
  return *this;
}

ColmapCommand& ColmapCommand::Arg(const std::string& key, double value) { return Arg(key, CanonicalDouble(value)); }

std::string ColmapCommand::ToString() const {
  std::string s = "colmap " + command;
  for (const auto& [k, v] : args) s += " " + k + " " + v;
  return s;
}

void CheckColmapAvailable() {
  const std::string exe = ColmapExecutable();
  bool found = exe.find('/') != std::string::npos && access(exe.c_str(), X_OK) == 0;
  const char* path = std::getenv("PATH");
  if (!found && exe.find('/') == std::string::npos && path != nullptr) {
    std::string dirs = path;
    size_t start = 0;
    while (!found && start <= dirs.size()) {
      const size_t end = std::min(dirs.find(':', start), dirs.size());
      const std::string candidate = dirs.substr(start, end - start) + "/" + exe;
      found = access(candidate.c_str(), X_OK) == 0;
      start = end + 1;
    }
  }
  if (!found) {
    RELIGHT_USER_ERROR()
        << "cannot run COLMAP ('" << exe
        << "'): install it with `apt-get install colmap` (Debian 12) or set RELIGHT_COLMAP to its path";
  }
}

ProcessResult RunColmap(const ColmapCommand& command, const std::function<void(const std::string&)>& on_line) {
  std::vector<std::string> args = {command.command};
  for (const auto& [k, v] : command.args) {
    args.push_back(k);
    args.push_back(v);
  }
  return RunColmapProcess(args, on_line);
}

bool ParseBracketCount(const std::string& line, const std::string& marker, int* done, int* total) {
  const size_t m = line.find(marker);
  if (m == std::string::npos) return false;
  const size_t open = line.find('[', m + marker.size());
  if (open == std::string::npos) return false;
  int a = 0, b = 0;
  if (std::sscanf(line.c_str() + open, "[%d/%d", &a, &b) != 2 || b <= 0) return false;
  *done = a;
  *total = b;
  return true;
}

}  // namespace relight
