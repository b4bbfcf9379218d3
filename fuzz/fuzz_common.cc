#include "fuzz_common.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

namespace relight::fuzz {

const std::string& ScratchDir() {
  static const std::string dir = [] {
    spdlog::set_level(spdlog::level::off);
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
    const std::filesystem::path d = base / ("relight-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d.string();
  }();
  return dir;
}

std::string WriteScratch(const std::string& name, std::string_view bytes) {
  const std::string path = ScratchDir() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f != nullptr) {
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
  }
  return path;
}

std::vector<std::string_view> SplitParts(std::string_view data, size_t parts) {
  std::vector<std::string_view> out;
  static constexpr std::string_view kSeparator = "\n%%\n";
  while (out.size() + 1 < parts) {
    const size_t at = data.find(kSeparator);
    if (at == std::string_view::npos) break;
    out.push_back(data.substr(0, at));
    data.remove_prefix(at + kSeparator.size());
  }
  out.push_back(data);
  return out;
}

}  // namespace relight::fuzz
