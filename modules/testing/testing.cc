#include "testing/testing.h"

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <stdexcept>

namespace relight::testing {
namespace fs = std::filesystem;

namespace {
std::string EnvOr(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return (v != nullptr && *v != '\0') ? v : fallback;
}
}  // namespace

std::string SourceDir() { return EnvOr("RELIGHT_SOURCE_DIR", RELIGHT_DEFAULT_SOURCE_DIR); }
std::string BinDir() { return EnvOr("RELIGHT_BIN_DIR", RELIGHT_DEFAULT_BIN_DIR); }
std::string SharedDataDir() { return EnvOr("RELIGHT_SHARED_DATA_DIR", RELIGHT_DEFAULT_SHARED_DATA_DIR); }
bool HasSharedData(const std::string& relative) { return fs::exists(fs::path(SharedDataDir()) / relative); }

TempDir::TempDir() {
  std::string pattern = (fs::temp_directory_path() / "relight-test-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  const char* keep = std::getenv("RELIGHT_KEEP_TEST_DIRS");
  if (keep != nullptr && std::string(keep) == "1") {
    std::cerr << "kept test folder " << path_ << "\n";
    return;
  }
  std::error_code ec;
  fs::remove_all(path_, ec);
}

int RunCommand(const std::string& command, std::string* output) {
  const std::string full = command + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer;
  std::string text;
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) text.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  if (output != nullptr) *output = text;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace relight::testing
