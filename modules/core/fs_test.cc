#include "core/fs.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(FsTest, AtomicWriteReplacesContent) {
  testing::TempDir dir;
  const std::string path = dir / "a.txt";
  WriteFileAtomic(path, "one");
  WriteFileAtomic(path, "two");
  EXPECT_EQ(ReadFileToString(path), "two");
  for (const auto& e : fs::directory_iterator(dir.path())) EXPECT_EQ(e.path().filename(), "a.txt");
}

TEST(FsTest, FailedWriteKeepsOldContentAndNamesPath) {
  testing::TempDir dir;
  const std::string path = dir / "a.txt";
  WriteFileAtomic(path, "old");
  try {
    WriteFileAtomic(dir / "missing/sub/a.txt", "x");
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("missing/sub/a.txt"), std::string::npos);
  }
  EXPECT_EQ(ReadFileToString(path), "old");
}

TEST(FsTest, AtomicFileCommitAndAbandon) {
  testing::TempDir dir;
  {
    AtomicFile f(dir / "img.exr");
    EXPECT_EQ(fs::path(f.temp_path()).extension(), ".exr");
    std::ofstream(f.temp_path()) << "data";
    f.Commit();
  }
  EXPECT_EQ(ReadFileToString(dir / "img.exr"), "data");
  std::string abandoned;
  {
    AtomicFile f(dir / "other.png");
    std::ofstream(f.temp_path()) << "partial";
    abandoned = f.temp_path();
  }
  EXPECT_FALSE(fs::exists(abandoned));
  EXPECT_FALSE(fs::exists(dir / "other.png"));
}

TEST(FsTest, RemoveTempFilesCleansLeftovers) {
  testing::TempDir dir;
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "sub/x.relight-tmp-123-0.png") << "half";
  std::ofstream(dir / "sub/keep.png") << "done";
  RemoveTempFiles(dir.path());
  EXPECT_FALSE(fs::exists(dir / "sub/x.relight-tmp-123-0.png"));
  EXPECT_TRUE(fs::exists(dir / "sub/keep.png"));
}

}  // namespace
}  // namespace relight
