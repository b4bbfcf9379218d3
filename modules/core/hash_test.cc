#include "core/hash.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(HashTest, KnownVectors) {
  // FIPS 180-2 test vectors.
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(HashTest, FolderDigestDependsOnContentAndNamesNotLocation) {
  testing::TempDir a, b;
  for (const auto* d : {&a, &b}) {
    fs::create_directories(*d / "sub");
    std::ofstream(*d / "x.jpg") << "pixels";
    std::ofstream(*d / "sub/y.jpg") << "more";
    std::ofstream(*d / ".hidden") << "ignored";
  }
  DigestCache cache;
  const std::string da = cache.Digest(a.path());
  EXPECT_EQ(da, cache.Digest(b.path()));
  std::ofstream(b / ".hidden") << "changed";  // hidden files ignored
  EXPECT_EQ(da, DigestCache().Digest(b.path()));
  std::ofstream(b / "sub/y.jpg") << "MORE";
  EXPECT_NE(da, DigestCache().Digest(b.path()));
  EXPECT_THROW(cache.Digest(a / "nope"), UserError);
}

TEST(HashTest, PersistentCacheReusesAndDetectsChange) {
  testing::TempDir dir;
  std::ofstream(dir / "f.bin") << "abc";
  {
    DigestCache cache(dir / "digests.json");
    EXPECT_EQ(cache.Digest(dir / "f.bin"), Sha256Hex("abc"));
    cache.Save();
  }
  EXPECT_TRUE(fs::exists(dir / "digests.json"));
  std::ofstream(dir / "f.bin") << "abcd";  // size changes -> stamp changes
  DigestCache cache(dir / "digests.json");
  EXPECT_EQ(cache.Digest(dir / "f.bin"), Sha256Hex("abcd"));
}

}  // namespace
}  // namespace relight
