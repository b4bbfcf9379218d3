#include "core/scratch_file.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <vector>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// Resident pages of this process (/proc/self/statm), in bytes.
uint64_t ResidentBytes() {
  std::ifstream in("/proc/self/statm");
  uint64_t size = 0, resident = 0;
  in >> size >> resident;
  return resident * static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
}

TEST(ScratchFileTest, AppendedBytesReadBackFromTheMappingAndLeaveNoName) {
  testing::TempDir dir;
  ScratchFile file(dir.path(), "test data");
  std::vector<uint32_t> a(1000), b(777);
  std::iota(a.begin(), a.end(), 5u);
  std::iota(b.begin(), b.end(), 90000u);
  file.Append(a.data(), a.size() * 4);
  file.Append(b.data(), b.size() * 4);
  EXPECT_EQ(file.size(), (a.size() + b.size()) * 4);
  // No directory entry while the file is in use.
  EXPECT_TRUE(fs::is_empty(dir.path()));
  const auto* p = reinterpret_cast<const uint32_t*>(file.Map());
  ASSERT_NE(p, nullptr);
  for (size_t k = 0; k < a.size(); ++k) ASSERT_EQ(p[k], a[k]);
  for (size_t k = 0; k < b.size(); ++k) ASSERT_EQ(p[a.size() + k], b[k]);
}

TEST(ScratchFileTest, DroppedPagesLeaveTheResidentSetAndReadBackUnchanged) {
  testing::TempDir dir;
  ScratchFile file(dir.path(), "test data");
  constexpr size_t kWords = size_t(16) << 20;  // 64 MiB
  std::vector<uint32_t> chunk(size_t(1) << 20);
  for (size_t base = 0; base < kWords; base += chunk.size()) {
    for (size_t k = 0; k < chunk.size(); ++k) chunk[k] = static_cast<uint32_t>(base + k) * 2654435761u;
    file.Append(chunk.data(), chunk.size() * 4);
  }
  std::vector<uint32_t>().swap(chunk);
  const auto* p = reinterpret_cast<const uint32_t*>(file.Map());
  uint64_t sum = 0;
  for (size_t k = 0; k < kWords; ++k) sum += p[k];
  const uint64_t touched = ResidentBytes();
  file.DropPages(0, file.size());
  const uint64_t dropped = ResidentBytes();
  // Tolerance: 4 MiB of the 64 MiB may stay (other allocations between the two readings).
  EXPECT_GT(touched, dropped + (uint64_t(60) << 20)) << "resident " << touched << " -> " << dropped;
  uint64_t again = 0;
  for (size_t k = 0; k < kWords; ++k) {
    ASSERT_EQ(p[k], static_cast<uint32_t>(k) * 2654435761u) << k;
    again += p[k];
  }
  EXPECT_EQ(again, sum);
}

TEST(ScratchFileTest, MissingFolderIsAUserErrorNamingIt) {
  testing::TempDir dir;
  const std::string missing = dir / "no/such/folder";
  try {
    ScratchFile file(missing, "transport rows");
    FAIL() << "no error";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("transport rows"), std::string::npos) << e.what();
  }
}

TEST(ScratchFileTest, AFullDiskIsAUserErrorNamingTheFolderAndTheSizeWritten) {
  // A file-size limit stands in for a full disk: write(2) fails part way, as with ENOSPC.
  testing::TempDir dir;
  ScratchFile file(dir.path(), "transport rows");
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit limited = old;
  limited.rlim_cur = 3 << 20;  // 3 MiB
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
  std::vector<char> mib(size_t(1) << 20, 'x');
  std::string message;
  try {
    for (int k = 0; k < 8; ++k) file.Append(mib.data(), mib.size());
  } catch (const UserError& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(message.empty()) << "8 MiB written past a 3 MiB limit";
  EXPECT_NE(message.find(dir.path()), std::string::npos) << message;
  EXPECT_NE(message.find("3 MiB"), std::string::npos) << message;
  EXPECT_NE(message.find("ulimit -f"), std::string::npos) << message;
  EXPECT_EQ(file.size(), uint64_t(3) << 20);
}

}  // namespace
}  // namespace relight
